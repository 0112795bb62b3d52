"""The odometry v window of replay/agreement: v as wheel-encoder odometry reports it."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from _agreement_fixtures import HIDDEN, ROBOT, hidden_params, spec, write_log, write_params

from robots.reduced import simulate
from sim2real.agreement.figures import AGREEMENT_KEYS, measure_agreement, run_ensemble
from sim2real.agreement.latency import REFERENCE_KEYS
from sim2real.agreement.replay import replay
from sim2real.cli import main
from sim2real.errors import Sim2RealValueError
from sim2real.logs import Trace, read_trace, write_velocity_log
from sysid.odometry import window_mean

WINDOW_S = 1.0 / 30.0


@pytest.fixture(scope="module")
def trace(tmp_path_factory: pytest.TempPathFactory) -> Trace:
    return read_trace(write_log(tmp_path_factory.mktemp("odom") / "log.mcap", duration_s=6.0))


def _brute_force(
    trace: Trace,
    run: Callable[[np.ndarray], np.ndarray],
    window_s: float,
    n_per_window: int = 2001,
) -> np.ndarray:
    """Moving average of a fine simulation: ``n_per_window`` samples per window, trapezoid.

    ``run(t_out)`` simulates from the first measurement (as replay does) and returns v at the
    sorted times ``t_out``; before the first measurement the base holds the measured start.
    """
    t = np.asarray(trace.meas_t_s)
    q = t[:, None] + np.linspace(-window_s, 0.0, n_per_window)[None, :]
    fine_t = np.unique(np.clip(q.ravel(), t[0], None))
    fine_v = np.asarray(run(fine_t))
    vq = np.interp(np.clip(q, t[0], None), fine_t, fine_v)
    return np.asarray(np.trapezoid(vq, q, axis=1) / window_s)


def _history(trace: Trace, delay_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    # the log starts with its first command at t = 0: replay adds (v0, w0) at -delay
    v0, w0 = float(trace.meas_v[0]), float(trace.meas_w[0])
    return (
        np.concatenate(([-delay_s], trace.cmd_t_s)),
        np.concatenate(([v0], trace.cmd_v)),
        np.concatenate(([w0], trace.cmd_w)),
    )


def test_windowed_reduced_replay_is_the_moving_average_of_a_fine_simulation(
    trace: Trace,
) -> None:
    p = hidden_params()
    sim = replay(trace, robot=ROBOT, params=p, engine="reduced", odom_v_window_s=WINDOW_S)
    v0, w0 = float(trace.meas_v[0]), float(trace.meas_w[0])
    cmd_t, cmd_v, cmd_w = _history(trace, p.delay_s)

    def run(t_out: np.ndarray) -> np.ndarray:
        resp = simulate(
            p,
            spec().geometry,
            cmd_t_s=cmd_t,
            cmd_v=cmd_v,
            cmd_w=cmd_w,
            t_out_s=t_out,
            v0=v0,
            w0=w0,
        )
        return resp.v

    expected = _brute_force(trace, run, WINDOW_S)
    np.testing.assert_allclose(sim.v, expected, rtol=0, atol=1e-6)
    assert sim.odom_v_window_s == WINDOW_S
    # the window matters here (steps of the command): it is not the instantaneous v
    inst = replay(trace, robot=ROBOT, params=p, engine="reduced")
    assert np.max(np.abs(sim.v - inst.v)) > 1e-3
    np.testing.assert_allclose(sim.w, inst.w, rtol=0, atol=1e-12)  # w stays instantaneous


def test_windowed_pybullet_replay_is_the_moving_average_of_a_fine_simulation(
    trace: Trace,
) -> None:
    from robots.pybullet_robot import PybulletRobot

    p = hidden_params()
    sim = replay(trace, robot=ROBOT, params=p, engine="pybullet", odom_v_window_s=WINDOW_S)
    v0, w0 = float(trace.meas_v[0]), float(trace.meas_w[0])
    cmd_t, cmd_v, cmd_w = _history(trace, p.delay_s)

    def run(t_out: np.ndarray) -> np.ndarray:
        robot = PybulletRobot(spec(), params=p, physics_hz=240.0)
        try:
            out = robot.replay(cmd_t_s=cmd_t, cmd_v=cmd_v, cmd_w=cmd_w, t_out_s=t_out, v0=v0, w0=w0)
        finally:
            robot.close()
        return np.asarray(out.v)

    expected = _brute_force(trace, run, WINDOW_S)
    np.testing.assert_allclose(sim.v, expected, rtol=0, atol=1e-6)
    inst = replay(trace, robot=ROBOT, params=p, engine="pybullet")
    assert np.max(np.abs(sim.v - inst.v)) > 1e-3
    np.testing.assert_allclose(sim.w, inst.w, rtol=0, atol=1e-9)


def test_window_zero_changes_nothing(trace: Trace) -> None:
    p = hidden_params()
    default = replay(trace, robot=ROBOT, params=p, engine="reduced")
    zero = replay(trace, robot=ROBOT, params=p, engine="reduced", odom_v_window_s=0.0)
    np.testing.assert_array_equal(zero.v, default.v)
    np.testing.assert_array_equal(zero.w, default.w)
    assert default.odom_v_window_s == 0.0
    assert measure_agreement(trace, zero).odom_v_window_s == 0.0


def test_window_removes_the_half_period_lag_of_encoder_odometry(tmp_path: Path) -> None:
    """A log whose v is the window mean of the true v: instantaneous replay looks ~W/2 early."""
    s, p = spec(), hidden_params()
    rng = np.random.default_rng(3)
    cmd_t = np.arange(0.0, 20.0, 0.1)
    cmd_v = np.repeat(rng.uniform(-0.2, 0.2, 11), 20)[: cmd_t.size]
    meas_t = np.arange(0.0, 20.0, WINDOW_S)
    fine = np.arange(0.0, 20.0, 1e-4)
    true_v = simulate(
        p, s.geometry, cmd_t_s=cmd_t, cmd_v=cmd_v, cmd_w=np.zeros_like(cmd_t), t_out_s=fine
    ).v
    path = tmp_path / "odom.mcap"
    write_velocity_log(
        path,
        cmd_t_ns=np.rint(cmd_t * 1e9).astype(np.int64) + 10**18,
        cmd_v=cmd_v,
        cmd_w=np.zeros_like(cmd_t),
        meas_t_ns=np.rint(meas_t * 1e9).astype(np.int64) + 10**18,
        meas_v=window_mean(fine, true_v, meas_t, WINDOW_S),
        meas_w=np.zeros_like(meas_t),
    )
    tr = read_trace(path)
    inst = measure_agreement(tr, replay(tr, robot=ROBOT, params=p, engine="reduced"))
    odom = measure_agreement(
        tr, replay(tr, robot=ROBOT, params=p, engine="reduced", odom_v_window_s=WINDOW_S)
    )
    assert inst.lag_s_v == pytest.approx(-WINDOW_S / 2, abs=0.004)
    assert abs(odom.lag_s_v) < 0.002
    assert odom.fit_percent_v > inst.fit_percent_v and odom.fit_percent_v > 99.5
    assert odom.rmse_v < 0.2 * inst.rmse_v
    assert odom.odom_v_window_s == WINDOW_S and inst.odom_v_window_s == 0.0
    assert tuple(odom.to_dict()) == AGREEMENT_KEYS  # the JSON keys of the issue, unchanged


@pytest.mark.parametrize("bad", [-0.01, 1.5, float("nan"), float("inf"), True])
def test_bad_window_names_the_argument(trace: Trace, bad: float) -> None:
    with pytest.raises(Sim2RealValueError, match=r"odom_v_window_s .*\[0, 1\]") as info:
        replay(trace, robot=ROBOT, engine="reduced", odom_v_window_s=bad)
    assert "1/30" in str(info.value)


def test_ensemble_members_use_the_window(trace: Trace) -> None:
    from tests.randomization_block import distribution_around

    # spread 0 and no noise: every member is the centre itself, the band the windowed replay
    dist = distribution_around(hidden_params(), ROBOT, noise_v=0.0, noise_w=0.0)
    ens = run_ensemble(
        trace,
        robot=ROBOT,
        distribution=dist,
        n=2,
        seed=0,
        spread=0.0,
        engine="reduced",
        odom_v_window_s=WINDOW_S,
    )
    p = dist.mean_params()
    sim = replay(trace, robot=ROBOT, params=p, engine="reduced", odom_v_window_s=WINDOW_S)
    np.testing.assert_allclose(ens.lo_v, sim.v, rtol=0, atol=1e-12)
    np.testing.assert_allclose(ens.hi_v, sim.v, rtol=0, atol=1e-12)


def test_cli_auto_window_is_one_odometry_period(tmp_path: Path) -> None:
    log = write_log(tmp_path / "val.mcap", duration_s=8.0)
    params = write_params(tmp_path / "p.yaml", HIDDEN)
    out = tmp_path / "agree.json"
    args = ["agree", str(log), "--robot", ROBOT, "--engine", "reduced", "--params", str(params)]
    report = tmp_path / "report.html"
    assert (
        main([*args, "--odom-v-window", "auto", "--json", str(out), "--report", str(report)]) == 0
    )
    assert "odometry v window" in report.read_text() and "0.03333 s" in report.read_text()
    figures = json.loads(out.read_text())
    assert tuple(figures) == (*AGREEMENT_KEYS, *REFERENCE_KEYS, "notes")
    trace = read_trace(log)

    def fit_v(window_s: float) -> float:
        sim = replay(trace, robot=ROBOT, params=hidden_params(), engine="reduced",
                     odom_v_window_s=window_s)  # fmt: skip
        return measure_agreement(trace, sim).fit_percent_v

    auto = fit_v(1.0 / spec().odometry.rate_hz)
    assert figures["fit_percent_v"] == pytest.approx(auto, abs=1e-9)
    assert abs(auto - fit_v(0.0)) > 1e-3 and abs(auto - fit_v(0.05)) > 1e-3
    assert main([*args, "--odom-v-window", "0.05", "--json", str(out)]) == 0
    assert json.loads(out.read_text())["fit_percent_v"] == pytest.approx(fit_v(0.05), abs=1e-9)


@pytest.mark.parametrize("bad", ["abc", "-1", "2", "nan", ""])
def test_cli_bad_window_exits_2_with_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], bad: str
) -> None:
    log = write_log(tmp_path / "val.mcap", duration_s=4.0)
    rc = main(["agree", str(log), "--robot", ROBOT, "--engine", "reduced", "--odom-v-window", bad])
    assert rc == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--odom-v-window" in err and repr(bad) in err
