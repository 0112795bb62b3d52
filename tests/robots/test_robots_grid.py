"""simulate_grid (many parameter sets of one log in one compiled call, the fit's Jacobian) is
bit for bit simulate, with np.interp's output arithmetic, in numba and in plain Python."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robots.errors import RobotsValueError
from robots.params import BaseGeometry, DriveParams
from robots.reduced import GridCommands, pack_params, simulate, simulate_grid

GEO = BaseGeometry(
    mass_kg=1.2, yaw_inertia_kgm2=0.012, wheel_radius_m=0.033, wheel_separation_m=0.2
)
BASE = DriveParams(
    motor_gain_nms_per_rad=0.006,
    speed_loop_ki_per_s=8.0,
    wheel_torque_max_nm=0.05,
    coulomb_v_fwd_n=0.2,
    coulomb_w_nm=0.01,
    accel_lim_v_mps2=1.5,
    wheel_speed_max_radps=7.0,
)


def _log(seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    cmd_t = np.cumsum(rng.uniform(0.05, 0.4, 40))
    meas_t = np.sort(rng.uniform(cmd_t[0], cmd_t[-1] + 1.0, 300))
    return cmd_t, rng.uniform(-0.3, 0.3, 40), rng.uniform(-2.5, 2.5, 40), meas_t


@settings(max_examples=12, deadline=None, derandomize=True)
@given(
    seed=st.integers(0, 10_000),
    delay_steps=st.lists(st.integers(0, 60), min_size=1, max_size=4),
    frac=st.floats(0.0, 0.999),
    timeout_s=st.sampled_from([np.inf, 0.3]),
)
def test_grid_rows_are_simulate_bit_for_bit(
    seed: int, delay_steps: list[int], frac: float, timeout_s: float
) -> None:
    cmd_t, cmd_v, cmd_w, t_q = _log(seed)
    dt = 0.005
    t0 = float(t_q[0]) - dt
    n = int(np.ceil((t_q[-1] - t0) / dt))
    rows = [BASE.replace(delay_s=k * dt, cmd_timeout_s=timeout_s) for k in delay_steps]
    cache = {
        k: GridCommands.build(
            cmd_t, cmd_v, cmd_w, t0_s=t0, dt_s=dt, n=n, delay_s=k * dt, timeout_s=timeout_s
        )
        for k in set(delay_steps)
    }
    cmds = [cache[k] for k in delay_steps]
    packed = np.stack([pack_params(p, GEO) for p in rows])
    shifts = frac * dt * np.arange(1, len(rows) + 1) / len(rows)
    kw = {"v0": 0.05, "w0": -0.3}
    v, w = simulate_grid(cmds, packed, t_q, shifts, **kw)
    pv, pw = simulate_grid(cmds, packed, t_q, shifts, python=True, **kw)
    assert np.array_equal(v, pv) and np.array_equal(w, pw)
    for c, p in enumerate(rows):
        ref = simulate(
            p,
            GEO,
            cmd_t_s=cmd_t,
            cmd_v=cmd_v,
            cmd_w=cmd_w,
            t_out_s=np.concatenate(([t0], t_q - shifts[c])),
            dt_s=dt,
            **kw,
        )
        assert np.array_equal(v[c], ref.v[1:]) and np.array_equal(w[c], ref.w[1:])
    assert np.ptp(v) > 0.05 and np.ptp(w) > 0.3  # the traces move


def test_simulate_reads_the_grid_as_np_interp_does() -> None:
    """Output times before, on and after the grid's points: np.interp's values exactly."""
    cmd_t, cmd_v, cmd_w, _ = _log(1)
    dt = 0.01
    t_out = np.concatenate(([0.5], 0.5 + dt * np.array([0.0, 1.0, 1.5, 7.0, 7.25]), [0.6]))
    t_out = np.sort(t_out)
    r = simulate(BASE, GEO, cmd_t_s=cmd_t, cmd_v=cmd_v, cmd_w=cmd_w, t_out_s=t_out, dt_s=dt)
    fine = simulate(
        BASE, GEO, cmd_t_s=cmd_t, cmd_v=cmd_v, cmd_w=cmd_w, t_out_s=0.5 + dt * np.arange(11),
        dt_s=dt,
    )  # fmt: skip
    grid = 0.5 + dt * np.arange(11)
    assert np.array_equal(r.v, np.interp(t_out, grid, fine.v))
    assert np.array_equal(r.w, np.interp(t_out, grid, fine.w))


def test_grid_commands_of_another_grid_are_refused() -> None:
    cmd_t, cmd_v, cmd_w, t_q = _log(2)
    kw = {"dt_s": 0.005, "n": 100, "delay_s": 0.0, "timeout_s": np.inf}
    a = GridCommands.build(cmd_t, cmd_v, cmd_w, t0_s=0.0, **kw)
    b = GridCommands.build(cmd_t, cmd_v, cmd_w, t0_s=0.1, **kw)
    packed = np.stack([pack_params(BASE, GEO)] * 2)
    with pytest.raises(RobotsValueError, match="one grid"):
        simulate_grid([a, b], packed, t_q, np.zeros(2), v0=0.0, w0=0.0)
    with pytest.raises(RobotsValueError, match="one GridCommands per parameter row"):
        simulate_grid([a], packed, t_q, np.zeros(2), v0=0.0, w0=0.0)
