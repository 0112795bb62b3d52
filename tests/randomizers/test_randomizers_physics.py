"""CameraPoseJitter and DynamicsRandomizer through the env protocols (and their absence)."""

from __future__ import annotations

import math
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml
from randomizers_testenv import (
    ForgetfulDriveEnv,
    IgnoringCameraEnv,
    LastFrameViewEnv,
    NavDouble,
    StaticViewEnv,
)

from randomizers import CameraPoseJitter, DynamicsRandomizer, default_bounds
from randomizers.errors import MissingProtocolError, RandomizationNotAppliedError
from robots.params import DriveParams

NOMINAL_XYZ = np.array([-0.087, -0.0125, 0.287])


def test_camera_jitter_statistics_per_episode() -> None:
    env = CameraPoseJitter(NavDouble(), position_std_m=0.02, orientation_std_deg=3.0)
    dp, dr = [], []
    for seed in range(300):
        _, info = env.reset(seed=seed)
        rec = info["randomization"]["CameraPoseJitter"]
        xyz, rpy = env.unwrapped.get_camera_pose()
        np.testing.assert_allclose(xyz, rec["xyz_m"])
        np.testing.assert_allclose(xyz - NOMINAL_XYZ, rec["position_offset_m"], atol=1e-12)
        dp.append(rec["position_offset_m"])
        dr.append(rpy)
    dp, dr = np.asarray(dp), np.asarray(dr)
    bound = 4 / math.sqrt(2 * dp.size)
    assert abs(dp.std() / 0.02 - 1) < bound
    assert abs(dr.std() / math.radians(3.0) - 1) < bound
    assert abs(dp.mean()) < 4 * 0.02 / math.sqrt(dp.size)


def test_camera_jitter_does_not_accumulate_and_view_changes() -> None:
    env = CameraPoseJitter(NavDouble(), position_std_m=0.05, orientation_std_deg=5.0)
    env.reset(seed=0)
    view_a = env.unwrapped.get_camera_view_matrix()
    for seed in range(1, 50):
        env.reset(seed=seed)
    env.reset(seed=0)
    np.testing.assert_allclose(env.unwrapped.get_camera_view_matrix(), view_a)
    # around the nominal pose, never a random walk
    assert np.linalg.norm(env.unwrapped.camera_xyz - NOMINAL_XYZ) < 0.5


def test_camera_jitter_per_step_sets_a_new_pose_each_step() -> None:
    env = CameraPoseJitter(NavDouble(), position_std_m=0.02, resample="step")
    env.reset(seed=0)
    poses = set()
    for _ in range(5):
        info = env.step(np.zeros(2, np.float32))[4]
        xyz = tuple(info["randomization"]["CameraPoseJitter"]["xyz_m"])
        assert np.allclose(env.unwrapped.camera_xyz, xyz)
        poses.add(xyz)
    assert len(poses) == 5


def test_camera_jitter_scale_zero_keeps_nominal_pose() -> None:
    env = CameraPoseJitter(NavDouble(), scale=0.0)
    env.reset(seed=0)
    np.testing.assert_array_equal(env.unwrapped.camera_xyz, NOMINAL_XYZ)


def test_camera_jitter_detects_an_ignored_set_pose() -> None:
    env = CameraPoseJitter(IgnoringCameraEnv())
    with pytest.raises(RandomizationNotAppliedError, match="get_camera_pose\\(\\) returned"):
        env.reset(seed=0)


def test_camera_jitter_detects_a_view_matrix_that_does_not_change() -> None:
    env = CameraPoseJitter(StaticViewEnv())
    with pytest.raises(RandomizationNotAppliedError, match="view_matrix\\(\\) did not change"):
        env.reset(seed=0)


def test_camera_jitter_verifies_envs_whose_view_is_the_last_rendered_frame() -> None:
    env = CameraPoseJitter(LastFrameViewEnv(), position_std_m=0.02)
    _obs, _ = env.reset(seed=0)
    assert env._view_checked
    rendered = env.unwrapped.get_camera_view_matrix()
    np.testing.assert_allclose(rendered, NavDouble.get_camera_view_matrix(env.unwrapped))
    broken = CameraPoseJitter(LastFrameViewEnv(use_pose=False), position_std_m=0.02)
    broken.reset()  # unseeded: no probe, nothing to compare with yet
    with pytest.raises(RandomizationNotAppliedError, match="did not change"):
        broken.reset(seed=1)


def test_camera_jitter_probe_is_done_once() -> None:
    env = CameraPoseJitter(LastFrameViewEnv(), position_std_m=0.02)
    calls = []
    original = env.unwrapped.reset
    env.unwrapped.reset = lambda **kw: calls.append(kw) or original(**kw)  # type: ignore[method-assign]
    for seed in range(3):
        env.reset(seed=seed)
    assert len(calls) == 4  # one probe + three resets


@pytest.mark.parametrize(
    ("wrapper", "kwargs", "method"),
    [
        (CameraPoseJitter, {}, "get_camera_pose"),
        (DynamicsRandomizer, {"uniform": {"delay_s": [0.0, 0.1]}}, "get_drive_params"),
    ],
)
def test_missing_protocol_names_method_and_env_class(wrapper, kwargs, method) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(MissingProtocolError) as err:
        wrapper(gym.make("CartPole-v1"), **kwargs)
    text = str(err.value)
    assert method in text and "CartPoleEnv" in text
    assert isinstance(err.value, AttributeError)


def test_dynamics_uniform_ranges_and_readback() -> None:
    env = DynamicsRandomizer(
        NavDouble(), uniform={"coulomb_v_fwd_n": [0.5, 1.5], "delay_s": [0.05, 0.15]}
    )
    values = []
    for seed in range(400):
        _, info = env.reset(seed=seed)
        rec = info["randomization"]["DynamicsRandomizer"]
        params = env.unwrapped.get_drive_params()
        assert params.coulomb_v_fwd_n == rec["coulomb_v_fwd_n"]
        assert params.delay_s == rec["delay_s"]
        assert params.motor_gain_nms_per_rad == 0.5  # untouched fields keep the env's value
        values.append(rec["coulomb_v_fwd_n"])
    v = np.asarray(values)
    assert 0.5 <= v.min() < 0.52 and 1.48 < v.max() <= 1.5
    assert abs(v.mean() - 1.0) < 4 * (1 / math.sqrt(12)) / math.sqrt(v.size)


def test_dynamics_scale_shrinks_range_about_its_centre() -> None:
    env = DynamicsRandomizer(NavDouble(), uniform={"coulomb_v_fwd_n": [0.5, 1.5]}, scale=0.2)
    v = [
        env.reset(seed=s)[1]["randomization"]["DynamicsRandomizer"]["coulomb_v_fwd_n"]
        for s in range(200)
    ]
    assert min(v) >= 0.9 and max(v) <= 1.1
    env.set_scale(0.0)
    _, info = env.reset(seed=1)
    assert info["randomization"]["DynamicsRandomizer"]["coulomb_v_fwd_n"] == 1.0


def test_dynamics_normal_is_clipped_to_physical_values() -> None:
    env = DynamicsRandomizer(
        NavDouble(),
        normal={"coulomb_w_nm": [0.01, 0.05], "motor_gain_nms_per_rad": [0.5, 1.0]},
        bounds={"added_mass_kg": [-1.0, 1.0]},
    )
    w, k = [], []
    for seed in range(300):
        rec = env.reset(seed=seed)[1]["randomization"]["DynamicsRandomizer"]
        w.append(rec["coulomb_w_nm"])
        k.append(rec["motor_gain_nms_per_rad"])
    assert min(w) == 0.0 and sum(x == 0.0 for x in w) > 100  # ~42 % below zero, clipped
    assert min(k) == pytest.approx(0.005)  # 1 % of the mean for must-be-positive gains
    assert default_bounds("added_mass_kg", 0.0) == (-math.inf, math.inf)


def test_dynamics_detects_an_env_that_forgets_params_on_reset() -> None:
    env = DynamicsRandomizer(ForgetfulDriveEnv(), uniform={"coulomb_v_fwd_n": [0.5, 1.5]})
    with pytest.raises(RandomizationNotAppliedError, match="after reset"):
        env.reset(seed=0)


def _params_file(tmp_path: Path) -> Path:
    """A turtlebot2 params file whose randomisation is centred on NavDouble-like values."""
    from robots.spec import load_spec
    from tests.randomization_block import write_params_file

    centre = load_spec("turtlebot2").drive.replace(delay_s=0.118, coulomb_v_fwd_n=2.0)
    return write_params_file(tmp_path / "params.yaml", centre, "turtlebot2", rel=0.5)


def test_from_sysid_draws_the_files_distribution(tmp_path: Path) -> None:
    from robots.randomization import DriveDistribution

    path = _params_file(tmp_path)
    dist = DriveDistribution.from_params_file(path, robot="turtlebot2")
    factory = DynamicsRandomizer.from_sysid(path, scale=1.0)
    env = factory(NavDouble())
    recs = [env.reset(seed=s)[1]["randomization"]["DynamicsRandomizer"] for s in range(400)]
    assert set(recs[0]) == {*dist.names, "scale"}
    delay = np.array([r["delay_s"] for r in recs])
    sd = dist.std()["delay_s"]  # delay is fitted in its own unit (lin coordinate)
    assert abs(delay.mean() - 0.118) < 4 * sd / 20
    assert abs(delay.std() / sd - 1) < 4 / math.sqrt(800)
    # the whole parameter set is the file's robot, not the env's (cmd_timeout_s is fixed)
    assert env.unwrapped.get_drive_params().cmd_timeout_s == dist.fixed["cmd_timeout_s"]
    assert env.unwrapped.get_drive_params() == env.params


def test_from_sysid_with_env_fields_and_scale(tmp_path: Path) -> None:
    env = DynamicsRandomizer.from_sysid(
        _params_file(tmp_path), env=NavDouble(), scale=0.0, fields=["delay_s"]
    )
    rec = env.reset(seed=0)[1]["randomization"]["DynamicsRandomizer"]
    assert rec == {"delay_s": pytest.approx(0.118), "scale": 0.0}
    assert env.spec is None or env.spec.kwargs.get("fields") in (None, ["delay_s"])


def test_from_sysid_spread_widens_the_same_draws(tmp_path: Path) -> None:
    """spread s: the draws of spread 1 moved s times as far from the mean, same seeds."""
    from randomizers import stream_generator
    from robots.params import SCHEMA
    from robots.randomization import DriveDistribution

    path = _params_file(tmp_path)
    dist = DriveDistribution.from_params_file(path, robot="turtlebot2")
    one = DynamicsRandomizer.from_sysid(path, env=NavDouble(), fields=["delay_s"])
    three = DynamicsRandomizer.from_sysid(path, env=NavDouble(), fields=["delay_s"], spread=3)
    centre = dist.mean_params().delay_s
    for seed in range(30):
        a = one.reset(seed=seed)[1]["randomization"]["DynamicsRandomizer"]["delay_s"]
        b = three.reset(seed=seed)[1]["randomization"]["DynamicsRandomizer"]["delay_s"]
        wide = centre + 3 * (a - centre)
        lo, hi = SCHEMA["delay_s"].coord_bounds(dist.geometry)  # draws stay in the schema range
        assert b == pytest.approx(min(max(wide, lo), hi), rel=1e-9, abs=1e-12)
    # the one sampler: the same draw as DriveDistribution.sample(spread=3) on the stream
    marginal = three.distribution
    want = marginal.sample(stream_generator(29, "DynamicsRandomizer"), 1, spread=3.0)[0]
    assert want.delay_s == pytest.approx(b)
    # curriculum scale composes: spread 3 at scale 0.5 is spread 1.5
    half = DynamicsRandomizer.from_sysid(
        path, env=NavDouble(), fields=["delay_s"], spread=3, scale=0.5
    )
    c = half.reset(seed=29)[1]["randomization"]["DynamicsRandomizer"]["delay_s"]
    assert c == pytest.approx(min(max(centre + 1.5 * (a - centre), lo), hi), rel=1e-9)
    assert half.spec is None or half.spec.kwargs.get("spread") in (None, 3.0)


@pytest.mark.parametrize("bad", [10.5, -1.0, math.inf, "3"])
def test_spread_is_bounded_and_needs_sysid(tmp_path: Path, bad: object) -> None:
    path = _params_file(tmp_path)
    with pytest.raises((ValueError, TypeError), match="spread"):
        DynamicsRandomizer.from_sysid(path, spread=bad)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"'spread' need 'sysid'"):
        DynamicsRandomizer(NavDouble(), normal={"delay_s": [0.1, 0.01]}, spread=2.0)


def test_spread_from_config_round_trips(tmp_path: Path) -> None:
    import randomizers

    path = _params_file(tmp_path)
    cfg = {
        "format": "sim2real.randomizers/1",
        "randomizers": [{"type": "DynamicsRandomizer", "sysid": str(path), "spread": 2.5}],
    }
    env = randomizers.from_config(NavDouble(), cfg)
    assert env.spread == 2.5
    assert randomizers.to_config(env)["randomizers"][0]["spread"] == 2.5
    with pytest.raises(ValueError, match=r"randomizers\[0\].*'spread' must be in \[0, 10\]"):
        randomizers.from_config(
            NavDouble(), {**cfg, "randomizers": [{**cfg["randomizers"][0], "spread": 11}]}
        )


def test_from_sysid_refuses_a_field_that_does_not_vary(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match=r"cmd_timeout_s.*do not vary"):
        DynamicsRandomizer.from_sysid(_params_file(tmp_path), fields=["cmd_timeout_s"])


def test_from_sysid_missing_file_is_a_clear_error(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="does not exist"):
        DynamicsRandomizer.from_sysid(tmp_path / "nope.yaml")


def test_from_sysid_refuses_a_file_without_randomization(tmp_path: Path) -> None:
    path = tmp_path / "old.yaml"
    doc = {"format": "sim2real.sysid/1", "robot": "turtlebot2", "parameters": {}}
    path.write_text(yaml.safe_dump(doc), encoding="utf-8")
    with pytest.raises(ValueError, match="no 'randomization' block"):
        DynamicsRandomizer.from_sysid(path)


def test_sysid_and_hand_ranges_do_not_mix(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="sysid"):
        DynamicsRandomizer(
            NavDouble(), sysid=_params_file(tmp_path), uniform={"delay_s": [0.0, 0.1]}
        )


def test_drive_params_stay_valid_dataclass() -> None:
    env = DynamicsRandomizer(NavDouble(), uniform={"motor_gain_nms_per_rad": [0.0, 0.2]})
    for seed in range(50):
        env.reset(seed=seed)
        assert isinstance(env.unwrapped.get_drive_params(), DriveParams)
