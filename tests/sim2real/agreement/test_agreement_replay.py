"""Replay of logged commands on the reduced model and on the pybullet robot."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from _agreement_fixtures import ROBOT, T0_NS, hidden_params, spec, write_log

from robots.reduced import simulate
from sim2real.agreement.figures import measure_agreement
from sim2real.agreement.replay import replay
from sim2real.errors import Sim2RealValueError
from sim2real.logs import Trace, read_trace, write_velocity_log


@pytest.fixture(scope="module")
def trace(tmp_path_factory: pytest.TempPathFactory) -> Trace:
    return read_trace(write_log(tmp_path_factory.mktemp("replay") / "log.mcap", duration_s=20.0))


def test_reduced_replay_is_the_reduced_model_at_the_odometry_times(trace: Trace) -> None:
    p = hidden_params()
    sim = replay(trace, robot=ROBOT, params=p, engine="reduced")
    v0, w0 = float(trace.meas_v[0]), float(trace.meas_w[0])
    # the log starts with its first command and odometry at t = 0: the replay adds the
    # synthetic start command (v0, w0) at -delay
    assert trace.cmd_t_s[0] == 0.0 and trace.meas_t_s[0] == 0.0
    ref = simulate(
        p, spec().geometry,
        cmd_t_s=np.concatenate(([-p.delay_s], trace.cmd_t_s)),
        cmd_v=np.concatenate(([v0], trace.cmd_v)), cmd_w=np.concatenate(([w0], trace.cmd_w)),
        t_out_s=trace.meas_t_s, v0=v0, w0=w0,
    )  # fmt: skip
    np.testing.assert_array_equal(sim.v, ref.v)
    np.testing.assert_array_equal(sim.w, ref.w)
    np.testing.assert_array_equal(sim.t_ns, trace.meas_t_ns)
    assert sim.engine == "reduced" and sim.robot == ROBOT and sim.params == p


def test_default_params_are_the_spec_defaults(trace: Trace) -> None:
    assert replay(trace, robot=ROBOT, engine="reduced").params == spec().drive


@pytest.mark.slow
def test_pybullet_replay_matches_the_reduced_model(trace: Trace) -> None:
    """Same drive chain, real rigid bodies: the two engines agree on (nearly) every sample."""
    p = hidden_params()
    bullet = replay(trace, robot=ROBOT, params=p, engine="pybullet")
    reduced = replay(trace, robot=ROBOT, params=p, engine="reduced")
    assert bullet.physics_hz == 240.0 and bullet.v.shape == trace.meas_v.shape
    both = np.mean((np.abs(bullet.v - reduced.v) <= 0.01) & (np.abs(bullet.w - reduced.w) <= 0.05))
    assert both > 0.97
    assert measure_agreement(trace, bullet).agreement > 0.95
    assert bullet.elapsed_s < bullet.duration_s  # faster than real time even on a busy machine


@pytest.mark.parametrize("engine", ["reduced", pytest.param("pybullet", marks=pytest.mark.slow)])
def test_initial_state_is_the_first_measurement(tmp_path: Path, engine: str) -> None:
    """A log that starts while the robot cruises at 0.15 m/s, 0.5 rad/s."""
    t = np.arange(0.0, 2.0, 1 / 30)
    cmd_t = np.arange(0.0, 2.0, 0.1)
    path = tmp_path / "moving.mcap"
    write_velocity_log(
        path,
        cmd_t_ns=T0_NS + np.rint(cmd_t * 1e9).astype(np.int64),
        cmd_v=np.full(cmd_t.size, 0.15),
        cmd_w=np.full(cmd_t.size, 0.5),
        meas_t_ns=T0_NS + np.rint(t * 1e9).astype(np.int64),
        meas_v=np.full(t.size, 0.15),
        meas_w=np.full(t.size, 0.5),
    )
    p = spec().drive.replace(coulomb_v_fwd_n=0.0, coulomb_w_nm=0.0)
    p = p.replace(viscous_v_ns_per_m=0.0, viscous_w_nms_per_rad=0.0)
    sim = replay(read_trace(path), robot=ROBOT, params=p, engine=engine)
    assert sim.v[0] == pytest.approx(0.15, abs=0.005) and sim.w[0] == pytest.approx(0.5, abs=0.02)
    np.testing.assert_allclose(sim.v, 0.15, atol=0.01)
    np.testing.assert_allclose(sim.w, 0.5, atol=0.05)


def test_bad_engine_and_trace_without_commands_are_refused(trace: Trace) -> None:
    with pytest.raises(Sim2RealValueError, match="engine"):
        replay(trace, robot=ROBOT, engine="gazebo")
    empty = Trace(
        cmd_t_ns=np.array([], dtype=np.int64), cmd_v=np.array([]), cmd_w=np.array([]),
        meas_t_ns=trace.meas_t_ns, meas_v=trace.meas_v, meas_w=trace.meas_w,
    )  # fmt: skip
    with pytest.raises(Sim2RealValueError, match="no velocity commands"):
        replay(empty, robot=ROBOT, engine="reduced")


@pytest.mark.slow
def test_commands_before_the_first_odometry_are_in_the_delay_line(tmp_path: Path) -> None:
    """Commands start 1 s before odometry is recorded; both engines agree from the start."""
    cmd_t = np.arange(0.0, 4.0, 0.1)
    meas_t = np.arange(1.0, 4.0, 1 / 30)
    p = hidden_params()
    true = simulate(
        p, spec().geometry, cmd_t_s=cmd_t, cmd_v=np.full(cmd_t.size, 0.2),
        cmd_w=np.full(cmd_t.size, 0.8), t_out_s=np.concatenate(([0.0], meas_t)),
    )  # fmt: skip
    path = tmp_path / "late_odom.mcap"
    write_velocity_log(
        path,
        cmd_t_ns=T0_NS + np.rint(cmd_t * 1e9).astype(np.int64),
        cmd_v=np.full(cmd_t.size, 0.2),
        cmd_w=np.full(cmd_t.size, 0.8),
        meas_t_ns=T0_NS + np.rint(meas_t * 1e9).astype(np.int64),
        meas_v=true.v[1:],
        meas_w=true.w[1:],
    )
    trace = read_trace(path)
    for engine in ("reduced", "pybullet"):
        sim = replay(trace, robot=ROBOT, params=p, engine=engine)
        np.testing.assert_allclose(sim.v, true.v[1:], atol=0.01)
        np.testing.assert_allclose(sim.w, true.w[1:], atol=0.05)


@pytest.mark.parametrize("engine", ["reduced", pytest.param("pybullet", marks=pytest.mark.slow)])
def test_the_base_stops_after_the_command_timeout(tmp_path: Path, engine: str) -> None:
    """Commands stop at 1 s; the spec's 0.5 s timeout stops the base, as the firmware does."""
    cmd_t = np.arange(0.0, 1.05, 0.1)
    meas_t = np.arange(0.0, 4.0, 1 / 30)
    path = tmp_path / "stop.mcap"
    write_velocity_log(
        path,
        cmd_t_ns=T0_NS + np.rint(cmd_t * 1e9).astype(np.int64),
        cmd_v=np.full(cmd_t.size, 0.15),
        cmd_w=np.zeros(cmd_t.size),
        meas_t_ns=T0_NS + np.rint(meas_t * 1e9).astype(np.int64),
        meas_v=np.zeros(meas_t.size),
        meas_w=np.zeros(meas_t.size),
    )
    p = spec().drive
    assert p.cmd_timeout_s == 0.5
    sim = replay(read_trace(path), robot=ROBOT, params=p, engine=engine)
    t = sim.t_s
    assert sim.v[(t > 0.8) & (t < 1.4)].min() > 0.12  # still driving until the timeout
    np.testing.assert_allclose(sim.v[t > 2.5], 0.0, atol=0.005)  # stopped


class _Reduced:
    """Another simulator for replay(): the reduced model with its own parameters."""

    name = "other"

    def __init__(self, params: object) -> None:
        self.params = params
        self.calls = 0

    def replay(self, cmd, t_out_s, start):  # type: ignore[no-untyped-def]
        self.calls += 1
        out = simulate(
            self.params, spec().geometry, cmd_t_s=cmd[0], cmd_v=cmd[1], cmd_w=cmd[2],
            t_out_s=t_out_s, v0=start[0], w0=start[1],
        )  # fmt: skip
        return np.asarray(out.v), np.asarray(out.w)


def test_another_simulator_is_replayed_like_the_named_engines(trace: Trace) -> None:
    p = hidden_params()
    other = _Reduced(p)
    sim = replay(trace, robot=ROBOT, params=p, engine=other)
    ref = replay(trace, robot=ROBOT, params=p, engine="reduced")
    assert other.calls == 1 and sim.engine == "other"
    np.testing.assert_array_equal(sim.v, ref.v)
    np.testing.assert_array_equal(sim.w, ref.w)
    with pytest.raises(Sim2RealValueError, match="engine"):
        replay(trace, robot=ROBOT, engine=object())  # type: ignore[arg-type]
