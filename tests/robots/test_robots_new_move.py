"""Firmware that runs each command as a new move: the wheel loops' integrators clear on a change.

``command_starts_new_move = 1`` (the Neato's ``SetMotor``): when a step's wheel targets differ
from the previous reference's, both wheel integrators start again from zero; a held command
integrates as before, so the loops still cancel the friction once a move settles.
``command_starts_new_move = 0`` (the default, every shipped spec): the loops run on. One kernel
function (:func:`robots._kernel.starts_new_move`): the reduced engine, the pybullet robot and
the MuJoCo drive (tests/sim2real/test_mujoco_robot.py) follow it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robots._kernel import pack_params, pybullet_substep
from robots.errors import RobotsValueError, SpecError
from robots.params import BaseGeometry, DriveParams, read_params_file
from robots.reduced import simulate
from robots.spec import list_robots, load_spec
from robots.template import spec_text
from tests.robots._modes import engines_and_modes

# a Neato-sized base (0.248 m track, the template's 0.0496 m wheels) on PI loops with friction
GEO = BaseGeometry(
    mass_kg=4.0, yaw_inertia_kgm2=0.04, wheel_radius_m=0.0496, wheel_separation_m=0.248
)
FRICTION = {"coulomb_v_fwd_n": 0.5, "coulomb_v_bwd_n": 0.5, "coulomb_w_nm": 0.02}  # N, N m
LOOP = DriveParams(
    motor_gain_nms_per_rad=0.02, speed_loop_ki_per_s=4.0, wheel_speed_max_radps=6.05, **FRICTION
)
NEW_MOVE = LOOP.replace(command_starts_new_move=1.0)


def _step_response(params: DriveParams) -> tuple[np.ndarray, np.ndarray]:
    """0.1 m/s for 1 s, then (0.2 m/s, 0.5 rad/s) held: (v, w) at 0, 0.2, 1, 1.2, 1.5, 2, 8 s."""
    out = simulate(
        params,
        GEO,
        cmd_t_s=np.array([0.0, 1.0]),
        cmd_v=np.array([0.1, 0.2]),
        cmd_w=np.array([0.0, 0.5]),
        t_out_s=np.array([0.0, 0.2, 1.0, 1.2, 1.5, 2.0, 8.0]),
    )
    return out.v, out.w


def test_step_response_golden_numbers_on_and_off() -> None:
    """Golden numbers (reduced engine, 240 Hz). Up to the change the two are the same motion.
    After it the loops run on with the integral built over the 0.1 m/s move (it held the
    Coulomb force, 0.5 N): off, v overshoots to 0.224 m/s at 1.5 s; a new move starts from a
    P loop, so v trails (0.162 against 0.177 m/s at 1.2 s) and peaks lower (0.211). w starts
    from rest, where both integrators hold nothing for it: the same in both. Held for 6 s,
    both reach the command exactly: the new move's integrator cancels the friction too."""
    v_off, w_off = _step_response(LOOP)
    v_on, w_on = _step_response(NEW_MOVE)
    np.testing.assert_allclose(
        v_off, [0.0, 0.05848, 0.11149, 0.17662, 0.2236, 0.20887, 0.2], atol=5e-5
    )
    np.testing.assert_allclose(
        v_on, [0.0, 0.05848, 0.11149, 0.1615, 0.2109, 0.21034, 0.2], atol=5e-5
    )
    np.testing.assert_array_equal(v_on[:3], v_off[:3])
    np.testing.assert_allclose(w_on, [0.0, 0.0, 0.0, 0.41111, 0.59182, 0.50842, 0.5], atol=5e-5)
    np.testing.assert_allclose(w_on, w_off, atol=1e-12)


@settings(max_examples=20, deadline=None)
# |w1| >= 0.1 rad/s or none: a smaller yaw error takes the integrator over 8 s to break the
# yaw Coulomb torque free (stiction, in both modes)
@given(
    v0=st.floats(-0.25, 0.25),
    v1=st.floats(0.05, 0.25),
    w1=st.one_of(st.just(0.0), st.floats(0.1, 1.5), st.floats(-1.5, -0.1)),
)
def test_a_held_command_settles_on_the_target_in_both_modes(
    v0: float, v1: float, w1: float
) -> None:
    """The integrator of a new move builds from zero and still cancels the Coulomb friction:
    after 8 s at (v1, w1) both modes hold the wheel targets (scaled together at the cap)."""
    half, r, cap = 0.5 * GEO.wheel_separation_m, GEO.wheel_radius_m, 6.05
    scale = min(1.0, cap * r / max(abs(v1 + w1 * half), abs(v1 - w1 * half)))
    args = {
        "cmd_t_s": np.array([0.0, 1.0]),
        "cmd_v": np.array([v0, v1]),
        "cmd_w": np.array([0.0, w1]),
        "t_out_s": np.array([0.0, 9.0]),
    }
    for params in (LOOP, NEW_MOVE):
        out = simulate(params, GEO, **args)
        assert out.v[-1] == pytest.approx(scale * v1, abs=1e-6)
        assert out.w[-1] == pytest.approx(scale * w1, abs=1e-6)


def test_rounding_of_the_held_command_is_not_a_new_move() -> None:
    """The reduced engine averages the delayed command over each step through its running
    integral, which leaves changes of ~1e-17 m/s in a held command: not a new move. A command
    held with a sub-step delay behaves as with none (the integral is kept)."""
    args = {"cmd_t_s": np.array([0.0]), "cmd_v": np.array([0.1]), "cmd_w": np.array([0.3])}
    t = np.array([0.0, 0.4, 1.0, 3.0])
    for delay in (0.0, 0.0137):
        p = NEW_MOVE.replace(delay_s=delay)
        on = simulate(p, GEO, t_out_s=t + delay, **args)
        off = simulate(p.replace(command_starts_new_move=0.0), GEO, t_out_s=t + delay, **args)
        np.testing.assert_allclose(on.v, off.v, atol=1e-12)
        np.testing.assert_allclose(on.w, off.w, atol=1e-12)


#: The shipped specs' kernel before the setting existed, bit for bit: the TurtleBot3 Burger
#: drive with a PI loop, Coulomb friction and a torque cap on random commands (seed 7).
GOLDEN_V = [0.0, -0.0009265461957141569, -0.11196294740618583, 0.13899700779222607]
GOLDEN_W = [0.0, 1.986142178939655, 0.4833501730855753, 0.26312506372850303]
GOLDEN_TORQUES = [0.07653640322244364, -0.004908017542162374]
GOLDEN_STATE = [0.2, -1.0, 0.1020833333333333, 0.32104323412921487, 0.7745495862383166]


def test_specs_without_the_setting_are_unchanged_bit_for_bit() -> None:
    spec = load_spec("turtlebot3_burger")
    assert spec.drive.command_starts_new_move == 0.0
    d = spec.drive.replace(
        speed_loop_ki_per_s=6.0, coulomb_v_fwd_n=0.3, coulomb_v_bwd_n=0.3, wheel_torque_max_nm=0.12
    )
    rng = np.random.default_rng(7)
    t = np.arange(0.0, 4.0, 0.1)
    v, w = rng.uniform(-0.25, 0.25, t.size), rng.uniform(-2.5, 2.5, t.size)
    out = simulate(
        d, spec.geometry, cmd_t_s=t, cmd_v=v, cmd_w=w, t_out_s=np.array([0.35, 1.05, 2.15, 3.95])
    )
    assert [float(x) for x in out.v] == GOLDEN_V
    assert [float(x) for x in out.w] == GOLDEN_W
    p = pack_params(d, spec.geometry)
    state = np.zeros(5)
    torques = (0.0, 0.0)
    for k in range(50):
        u_w = 1.0 if k < 25 else -1.0
        torques = pybullet_substep(
            state, 0.2, u_w, 0.1 * k, 0.1 * k, 0.004 * k, 0.0, 0.02 * k, 1 / 240, p, 1e-4
        )
    assert [float(x) for x in torques] == GOLDEN_TORQUES
    assert [float(x) for x in state] == GOLDEN_STATE


def test_default_and_shipped_specs_keep_their_loops(tmp_path: Path) -> None:
    assert DriveParams().command_starts_new_move == 0.0
    for name in list_robots():  # OpenCR, Kobuki: PI loops that run on across commands
        assert load_spec(name).drive.command_starts_new_move == 0.0, name
    text = spec_text("neato", wheel_separation_m=0.248, max_speed_mps=0.3, new_move=True)
    path = tmp_path / "neato.yaml"
    path.write_text("\n".join(ln for ln in text.splitlines() if "command_starts" not in ln))
    assert load_spec(path).drive.command_starts_new_move == 0.0  # left out: the loops run on


#: The driver modes (0 or 1, never fitted): (field, robots new facts that set it to 1).
MODES = [
    ("command_starts_new_move", {"new_move": True}),
    ("wheel_cap_per_side", {"wheel_cap": "per-side"}),
]


@pytest.mark.parametrize("value", [0.5, 2.0, -1.0])
@pytest.mark.parametrize("field", [m[0] for m in MODES])
def test_a_mode_other_than_0_or_1_is_refused(field: str, value: float) -> None:
    with pytest.raises(RobotsValueError, match=rf"{field}' must be one of \[0, 1\]"):
        DriveParams(**{field: value})


@pytest.mark.parametrize(("field", "facts"), MODES)
def test_spec_params_file_and_robots_new_carry_the_mode(
    field: str, facts: dict[str, object], tmp_path: Path
) -> None:
    text = spec_text("neato", wheel_separation_m=0.248, max_speed_mps=0.3, **facts)  # type: ignore[arg-type]
    assert f"{field}: 1  # given" in text
    spec_path = tmp_path / "neato.yaml"
    spec_path.write_text(text)
    assert getattr(load_spec(spec_path).drive, field) == 1.0
    bad = tmp_path / "bad.yaml"
    bad.write_text(text.replace(f"{field}: 1", f"{field}: 3"))
    with pytest.raises(SpecError, match=rf"{field}.*must be one of"):
        load_spec(bad)
    params = tmp_path / "params.yaml"
    params.write_text(
        f"format: sim2real.sysid/1\nrobot: neato\nparameters:\n  {field}: {{value: 1.0}}\n"
    )
    assert read_params_file(params).values == {field: 1.0}
    off = spec_text("neato", wheel_separation_m=0.248, max_speed_mps=0.3)
    assert f"{field}: 0  # prior" in off


@pytest.mark.slow
def test_reduced_and_pybullet_agree_on_new_moves(tmp_path: Path) -> None:
    """A Neato-like base on PI loops with friction, commands changing every 0.1-0.5 s: the
    two engines clear the integrators alike (the modes part 10x more than the engines)."""
    path = tmp_path / "neato.yaml"
    path.write_text(spec_text("neato", wheel_separation_m=0.248, max_speed_mps=0.3, new_move=True))
    spec = load_spec(path)
    params = spec.drive.replace(
        delay_s=0.0, speed_loop_ki_per_s=6.0, coulomb_v_fwd_n=0.8, coulomb_v_bwd_n=0.8
    )
    assert params.command_starts_new_move == 1.0
    rng = np.random.default_rng(5)
    commands: list[tuple[float, float]] = []
    for n in rng.integers(2, 10, 12):
        commands += [(float(rng.uniform(0.05, 0.3)), float(rng.uniform(-1.0, 1.0)))] * int(n)
    rms_v, rms_w, parted, _ = engines_and_modes(spec, params, "command_starts_new_move", commands)
    assert parted > 10 * rms_v and parted > 0.01
    assert rms_v < 2e-3
    assert rms_w < 5e-3
