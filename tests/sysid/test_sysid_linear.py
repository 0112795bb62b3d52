"""Step and frequency figures of the identified first-order-plus-dead-time axis, checked
against a sampled step response and frequency sweep of the same transfer function."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sysid._linear import first_order_stats


def _sampled(gain: float, tau: float, delay: float) -> tuple[float, float, float]:
    t = np.linspace(0.0, delay + 20.0 * tau, 400_001)
    y = np.where(t >= delay, gain * (1.0 - np.exp(-(t - delay) / tau)), 0.0)
    rise = t[np.argmax(y >= 0.9 * gain)] - t[np.argmax(y >= 0.1 * gain)]
    outside = np.abs(y - gain) > 0.02 * abs(gain)
    settle = t[np.nonzero(outside)[0][-1] + 1]
    w = np.logspace(-3, 4, 200_001)
    mag = np.abs(gain / (1j * w * tau + 1.0))
    bw = w[np.argmax(mag < abs(gain) * 10 ** (-3 / 20))]
    return float(rise), float(settle), float(bw)


@settings(max_examples=25, deadline=None)
@given(
    gain=st.floats(0.2, 2.0),
    tau=st.floats(0.02, 1.0),
    delay=st.floats(0.0, 0.5),
)
def test_figures_match_the_sampled_response(gain: float, tau: float, delay: float) -> None:
    s = first_order_stats(gain, tau, delay)
    rise, settle, bw = _sampled(gain, tau, delay)
    step = (delay + 20.0 * tau) / 400_000
    assert s["rise_time_s"] == pytest.approx(rise, abs=3 * step)
    assert s["settling_time_s"] == pytest.approx(settle, abs=3 * step)
    assert s["bandwidth_radps"] == pytest.approx(bw, rel=1e-3)
    assert s["delay_s"] == pytest.approx(delay)


def test_a_long_delay_does_not_lengthen_the_rise_time() -> None:
    # a Pade approximant's undershoot used to count as rise time (0.28 s instead of 0.11 s)
    s = first_order_stats(0.9, 0.05, 0.2)
    assert s["rise_time_s"] == pytest.approx(0.05 * np.log(9.0), rel=1e-12)
    assert s["settling_time_s"] == pytest.approx(0.2 + 0.05 * np.log(50.0), rel=1e-12)


@pytest.mark.parametrize("tau", [0.0, -1.0, float("inf"), float("nan")])
def test_no_figures_without_a_positive_finite_time_constant(tau: float) -> None:
    assert first_order_stats(1.0, tau, 0.1) == {}
