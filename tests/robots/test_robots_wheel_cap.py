"""How the driver holds wheel targets to the speed cap: both scaled together or each clipped.

``wheel_cap_per_side = 0`` (the default, every shipped spec): a target beyond
``wheel_speed_max_radps`` scales both by one factor, keeping the turn's curvature.
``wheel_cap_per_side = 1``: each side's target is clipped on its own (a skid steer whose
encoders read each side's commanded speed clipped at the cap), so a fast turn loses yaw rate
on the outer side only. One kernel entry: the reduced engine and the pybullet robot (and the
MuJoCo drive, tests/sim2real/test_mujoco_robot.py) follow it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robots.errors import RobotsValueError
from robots.params import BaseGeometry, DriveParams
from robots.reduced import simulate
from robots.spec import list_robots, load_spec
from robots.template import spec_text
from tests.robots._modes import engines_and_modes

GEO = BaseGeometry(
    mass_kg=150.0, yaw_inertia_kgm2=30.0, wheel_radius_m=0.3, wheel_separation_m=1.08
)
# a PI loop with no friction: the steady wheel speeds are the targets exactly
LOOP = DriveParams(motor_gain_nms_per_rad=40.0, speed_loop_ki_per_s=4.0, wheel_speed_max_radps=13.1)


def _steady(params: DriveParams, v: float, w: float) -> tuple[float, float]:
    out = simulate(
        params,
        GEO,
        cmd_t_s=np.array([0.0]),
        cmd_v=np.array([v]),
        cmd_w=np.array([w]),
        t_out_s=np.array([0.0, 20.0]),
    )
    return float(out.v[-1]), float(out.w[-1])


def _body(right: float, left: float) -> tuple[float, float]:
    r, b = GEO.wheel_radius_m, GEO.wheel_separation_m
    return 0.5 * r * (right + left), r * (right - left) / b


@settings(max_examples=25, deadline=None)
@given(v=st.floats(-4.0, 4.0), w=st.floats(-4.0, 4.0))
def test_per_side_clips_each_target_and_joint_scales_both(v: float, w: float) -> None:
    r, half, cap = GEO.wheel_radius_m, 0.5 * GEO.wheel_separation_m, 13.1
    right, left = (v + w * half) / r, (v - w * half) / r
    clipped = _body(float(np.clip(right, -cap, cap)), float(np.clip(left, -cap, cap)))
    scale = min(1.0, cap / max(abs(right), abs(left), 1e-12))
    assert _steady(LOOP.replace(wheel_cap_per_side=1.0), v, w) == pytest.approx(clipped, abs=1e-6)
    assert _steady(LOOP, v, w) == pytest.approx((scale * v, scale * w), abs=1e-6)


def test_the_warthog_turn_the_modes_part_on() -> None:
    """The Warthog's recorded command (-3.72 m/s, -0.95 rad/s), right wheel 14.1 rad/s over a
    13.1 cap: clipping each side gives the measured w -0.65 rad/s, scaling both -0.88."""
    v_side, w_side = _steady(LOOP.replace(wheel_cap_per_side=1.0), -3.72, -0.95)
    v_joint, w_joint = _steady(LOOP, -3.72, -0.95)
    assert w_side == pytest.approx(-0.66, abs=0.01) and v_side == pytest.approx(-3.57, abs=0.01)
    assert w_joint == pytest.approx(-0.88, abs=0.01) and v_joint == pytest.approx(-3.45, abs=0.01)


def test_below_the_cap_the_modes_are_the_same() -> None:
    t = np.arange(0.0, 6.0, 0.1)
    rng = np.random.default_rng(3)
    v, w = rng.uniform(-1.0, 1.0, t.size), rng.uniform(-1.0, 1.0, t.size)  # wheels <= 5.1 rad/s
    args = {"cmd_t_s": t, "cmd_v": v, "cmd_w": w, "t_out_s": t}
    joint = simulate(LOOP, GEO, **args)
    side = simulate(LOOP.replace(wheel_cap_per_side=1.0), GEO, **args)
    np.testing.assert_array_equal(joint.v, side.v)
    np.testing.assert_array_equal(joint.w, side.w)


#: Shipped specs whose firmware clips each wheel target on its own (OpenCR's controlMotor).
PER_SIDE = {"turtlebot3_waffle_pi"}


def test_default_and_shipped_specs_cap_as_their_firmware_does(tmp_path: Path) -> None:
    assert DriveParams().wheel_cap_per_side == 0.0
    for name in list_robots():
        assert load_spec(name).drive.wheel_cap_per_side == float(name in PER_SIDE), name
    # a spec may leave the key out: both scaled together
    text = spec_text("w", wheel_separation_m=1.08, wheel_cap="per-side")
    path = tmp_path / "w.yaml"
    path.write_text("\n".join(ln for ln in text.splitlines() if "wheel_cap_per_side" not in ln))
    assert load_spec(path).drive.wheel_cap_per_side == 0.0


def test_robots_new_refuses_an_unknown_cap_mode() -> None:
    """(The mode's round trip and bad values: tests/robots/test_robots_new_move.py.)"""
    with pytest.raises(RobotsValueError, match="wheel_cap must be one of"):
        spec_text("w", wheel_separation_m=1.08, wheel_cap="each")


@pytest.mark.slow
def test_reduced_and_pybullet_agree_with_per_side_clipping(tmp_path: Path) -> None:
    """A skid steer driven beyond its cap in turns: both engines clip each side alike."""
    path = tmp_path / "skid.yaml"
    path.write_text(
        spec_text(
            "skid",
            wheel_separation_m=0.555,
            wheel_radius_m=0.165,
            mass_kg=50.0,
            max_speed_mps=1.0,
            drive="skid",
            wheel_cap="per-side",
        )
    )
    spec = load_spec(path)
    params = spec.drive.replace(delay_s=0.0, accel_lim_v_mps2=2.0, accel_lim_w_radps2=6.0)
    commands = [(0.9, 0.0)] * 10 + [(0.9, 2.5)] * 16 + [(-0.8, -2.5)] * 16
    rms_v, rms_w, _, parted = engines_and_modes(spec, params, "wheel_cap_per_side", commands)
    assert parted > 0.1  # the modes part by 20x more than the engines may
    assert rms_v < 2e-3
    assert rms_w < 5e-3
