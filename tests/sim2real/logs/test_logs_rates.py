"""A topic's rate in ``logs info``: a mean over enough, evenly spread messages, else none;
the standard ROS message packages are known."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from sim2real.logs._bags import _known_type
from sim2real.logs._info import topic_rate_hz

T0_NS = 1_700_000_000_000_000_000


@given(
    rate_hz=st.floats(0.5, 500.0),
    n=st.integers(10, 2000),
    jitter=st.floats(0.0, 0.3),
    seed=st.integers(0, 2**31 - 1),
)
def test_a_regular_stream_has_its_rate(rate_hz: float, n: int, jitter: float, seed: int) -> None:
    if (n - 1) / rate_hz < 1.5:
        n = int(np.ceil(1.5 * rate_hz)) + 1  # over a second of messages, jitter and all
    rng = np.random.default_rng(seed)
    t = T0_NS + np.round(1e9 * (np.arange(n) + jitter * rng.uniform(-0.5, 0.5, n)) / rate_hz)
    t = np.sort(t.astype(np.int64))
    got = topic_rate_hz(t)
    assert got is not None
    assert got == pytest.approx((n - 1) / ((t[-1] - t[0]) / 1e9))
    assert got == pytest.approx(rate_hz, rel=0.5 / (n - 1) + 1e-6)


def test_too_few_too_short_or_bursty_streams_have_no_rate() -> None:
    assert topic_rate_hz(np.array([], np.int64)) is None
    assert topic_rate_hz(np.array([T0_NS])) is None  # one /tf_static message
    assert topic_rate_hz(T0_NS + np.arange(9) * 10**9) is None  # 9 messages
    assert topic_rate_hz(T0_NS + np.arange(50) * 10**7) is None  # 50 in 0.49 s
    startup = T0_NS + np.arange(11) * 2 * 10**7  # /rosout: 11 lines in 0.2 s ...
    late = np.array([T0_NS + 4 * 10**9])  # ... and one 4 s later
    assert topic_rate_hz(np.concatenate([startup, late])) is None
    held = [T0_NS + k * 10**10 + np.arange(30) * 3 * 10**7 for k in range(5)]  # teleop keys
    assert topic_rate_hz(np.concatenate(held)) is None


def test_regular_pairs_keep_their_mean_rate() -> None:
    pairs = T0_NS + np.repeat(np.arange(50) * 10**9, 2) + np.tile([0, 10**6], 50)  # bonds
    assert topic_rate_hz(pairs) == pytest.approx(99 / 49.001)


@pytest.mark.parametrize(
    "type_name",
    [
        "tf2_msgs/msg/TFMessage",
        "tf/msg/tfMessage",
        "rcl_interfaces/msg/Log",
        "rosgraph_msgs/msg/Log",
        "diagnostic_msgs/msg/DiagnosticArray",
        "sensor_msgs/msg/LaserScan",
        "bond/msg/Status",
    ],
)
def test_standard_packages_are_known(type_name: str) -> None:
    assert _known_type(type_name)


def test_every_type_of_rosbags_stores_is_standard_and_custom_ones_are_not() -> None:
    from rosbags.typesys import Stores, get_typestore

    for store in (Stores.ROS1_NOETIC, Stores.LATEST):
        unknown = [name for name in get_typestore(store).types if not _known_type(name)]
        assert unknown == [], store
    assert not _known_type("neato_node/msg/Bump")
    assert not _known_type("my_robot_msgs/msg/WheelTicks")
