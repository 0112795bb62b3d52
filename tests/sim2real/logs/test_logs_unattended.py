"""Unattended segments: motion with no command in force, commands held while the wheels stop."""

from __future__ import annotations

import html
import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robots.spec import load_spec
from sim2real.cli import main
from sim2real.logs import Trace, TraceMeta, find_unattended, read_trace, write_trace
from sim2real.plants.diff_drive import make_fleet
from sysid.metrics import active_mask

_T0 = 1_700_000_000_000_000_000


def _trace(v_meas: np.ndarray, v_cmd: np.ndarray, hz: float = 10.0) -> Trace:
    t = _T0 + np.rint(np.arange(v_meas.size) / hz * 1e9).astype(np.int64)
    return Trace(
        cmd_t_ns=t,
        cmd_v=v_cmd,
        cmd_w=np.zeros(t.size),
        meas_t_ns=t,
        meas_v=v_meas,
        meas_w=np.zeros(t.size),
        meta=TraceMeta(path="built.mcap"),
    )


def test_the_rules_on_a_built_recording() -> None:
    """Hand-driven motion and a command held at a stop are flagged; coasting and delay not."""
    t = np.arange(600) / 10.0
    cmd = np.where((t >= 5) & (t < 15), 0.3, 0.0)  # driven 5-15 s by the recorded command
    cmd[(t >= 40)] = 0.2  # the script's last command, held while the driver is disabled
    real = np.zeros(t.size)
    real[(t >= 5.4) & (t < 15.5)] = 0.3  # answers 0.4 s late, coasts 0.5 s after the stop
    real[(t >= 25) & (t < 32)] = 0.25  # a joystick the recording did not hold
    found = find_unattended(_trace(real, cmd))
    assert found.ranges_s == ((25.0, 31.9), (40.0, 59.9))
    assert found.motion[(t >= 25) & (t < 32)].all() and not found.motion[t < 24].any()
    assert found.stopped[t >= 40].all() and not found.stopped[t < 40].any()
    assert found.share == pytest.approx(270 / 375)  # of the 375 active samples
    assert "--keep-all keeps them" in found.note("built.mcap")


def _delete_blocks(
    trace: Trace, rng: np.random.Generator, share: float = 0.2
) -> tuple[Trace, np.ndarray, np.ndarray]:
    """``trace`` with ~``share`` of its command messages deleted in 2-6 s blocks.

    Returns the new trace, the affected samples (inside a deleted span and active under the
    true or the remaining commands) and the active samples of the original.
    """
    ct = trace.cmd_t_s
    n = ct.size
    rate = 1.0 / float(np.median(np.diff(ct)))
    keep = np.ones(n, dtype=bool)
    for _ in range(1000):
        if (~keep).sum() >= share * n:
            break
        length = int(rng.uniform(2.0, 6.0) * rate)
        i0 = int(rng.integers(1, max(2, n - length - 1)))
        i1 = min(n - 1, i0 + length)
        if keep[max(0, i0 - 2) : i1 + 2].all():
            keep[i0:i1] = False
    t = trace.meas_t_s
    gone = np.flatnonzero(~keep)
    starts = gone[np.r_[True, np.diff(gone) > 1]]
    ends = gone[np.r_[np.diff(gone) > 1, True]] + 1
    inside = np.zeros(t.size, dtype=bool)
    for a, b in zip(starts, ends, strict=True):
        inside |= (t >= ct[a]) & (t < (ct[b] if b < n else np.inf))
    new = trace._slice(np.ones(t.size, dtype=bool), keep)
    acts = [
        active_mask(*tr.cmd_at_meas(), trace.meas_v, trace.meas_w, tol_v=0.02, tol_w=0.1)
        for tr in (trace, new)
    ]
    return new, inside & (acts[0] | acts[1]), acts[0]


def _score(
    traces: list[Trace], tmp: Path, seed: int, timeout_s: list[float]
) -> tuple[float, float]:
    """Pooled share of affected samples flagged and of the other active samples flagged.

    Each trace with deleted commands is written as an MCAP and read back, as a user's log.
    """
    rng = np.random.default_rng(seed)
    hit = n_aff = false = n_other = 0
    for k, (trace, timeout) in enumerate(zip(traces, timeout_s, strict=True)):
        new, affected, active = _delete_blocks(trace, rng)
        back = read_trace(write_trace(tmp / f"deleted_{k}.mcap", new))
        flagged = find_unattended(back, cmd_timeout_s=timeout).flagged
        others = ~affected & active
        hit += int(flagged[affected].sum())
        n_aff += int(affected.sum())
        false += int(flagged[others].sum())
        n_other += int(others.sum())
    return hit / n_aff, false / n_other


@pytest.mark.slow
def test_deleted_command_blocks_in_plant_logs_are_found(tmp_path: Path) -> None:
    """~20 % of the commands deleted in blocks: >= 90 % of affected samples flagged, < 2 %
    of the others (plant logs of three bases, go-to-goal, mixed and teleop driving)."""
    traces, timeouts = [], []
    for robot in ("turtlebot2", "turtlebot3_burger", "turtlebot3_waffle_pi"):
        for profile in ("mixed", "goals", "teleop"):
            traces += make_fleet(robot, 2, seed=5, duration_s=60.0, profile=profile)
            timeouts += [load_spec(robot).drive.cmd_timeout_s] * 2
    recall, false = _score(traces, tmp_path, seed=1, timeout_s=timeouts)
    assert recall >= 0.9
    assert false < 0.02


@pytest.mark.realdata
def test_deleted_command_blocks_in_real_logs_are_found(realdata_dir: Path, tmp_path: Path) -> None:
    """The same on real recordings whose controller publishes at a steady rate."""
    names = (
        "tb3wp_drexel_goal.mcap",
        "neato_paulruvolo-pr5_obstacle-avoid_2017-02-06-16-23-52.mcap",
        "neato_paulruvolo-pr2_person_follower_bag_2017-02-04-15-10-28.mcap",
        "neato_yycho0108_drive_square_demo.mcap",
    )
    traces = [read_trace(realdata_dir / n) for n in names]
    assert all(not find_unattended(tr).flagged.any() for tr in traces)  # clean as recorded
    recall, false = _score(traces, tmp_path, seed=2, timeout_s=[np.inf] * len(traces))
    assert recall >= 0.9
    assert false < 0.02


@pytest.mark.realdata
def test_real_unattended_segments(realdata_dir: Path) -> None:
    """A Husky script's last command held after the end; a Warthog driven by hand."""
    husky = find_unattended(read_trace(realdata_dir / "husky_lifted_a" / "trace.csv"))
    assert len(husky.ranges_s) == 1 and husky.ranges_s[0][0] > 300 and husky.stopped.any()
    assert not husky.motion.any()
    warthog = find_unattended(read_trace(realdata_dir / "warthog_close" / "trace.csv"))
    assert warthog.motion.any() and warthog.stopped.any() and 0.3 < warthog.share < 0.5


def _write(path: Path, real: np.ndarray, cmd: np.ndarray) -> Path:
    return write_trace(path, _trace(real, cmd))


def _agree(*args: str | Path) -> int:
    return main(["agree", *map(str, args), "--robot", "turtlebot2", "--engine", "reduced"])


def _joystick() -> tuple[np.ndarray, np.ndarray]:
    """``(real, cmd)`` v of 60 s at 10 Hz: two commanded drives, a joystick at 22-27 s."""
    t = np.arange(600) / 10.0
    cmd = np.where(((t >= 5) & (t < 15)) | ((t >= 35) & (t < 45)), 0.3, 0.0)
    real = np.zeros(t.size)
    real[((t >= 5.4) & (t < 15.5)) | ((t >= 35.4) & (t < 45.5))] = 0.3
    real[(t >= 22) & (t < 27)] = 0.25  # a joystick
    return real, cmd


def test_agree_leaves_them_out_with_one_note_and_keep_all_keeps_them(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    real, cmd = _joystick()
    log = _write(tmp_path / "joy.mcap", real, cmd)
    out, report = tmp_path / "a.json", tmp_path / "r.html"
    assert _agree(log, "--json", out, "--report", report) == 0
    stdout = capsys.readouterr().out
    notes = [ln for ln in stdout.splitlines() if ln.startswith("note: left out")]
    assert len(notes) == 1 and "22.0-26.9 s" in notes[0]
    assert "moved with no command in force" in notes[0]
    assert notes[0] in html.unescape(report.read_text())  # the report says it too
    screened = json.loads(out.read_text())
    assert _agree(log, "--json", out, "--keep-all") == 0
    assert "note: left out" not in capsys.readouterr().out
    kept = json.loads(out.read_text())
    assert kept["n_samples"] - screened["n_samples"] == 50
    assert screened["agreement"] > kept["agreement"]


@pytest.mark.parametrize("kind", ["hand", "stopped"])
def test_a_mostly_unattended_log_is_refused_in_one_sentence(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], kind: str
) -> None:
    t = np.arange(400) / 10.0
    moving = np.where(t > 3, 0.3, 0.0)
    real, cmd = (moving, np.zeros(t.size)) if kind == "hand" else (np.zeros(t.size), moving)
    log = _write(tmp_path / f"{kind}.mcap", real, cmd)
    assert _agree(log) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert "is mostly unattended" in err and "--keep-all" in err
    fit = ["sysid", "fit", str(log), "--robot", "turtlebot2", "-o", str(tmp_path / "p.yaml")]
    assert main(fit) == 2
    assert "is mostly unattended" in capsys.readouterr().err


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    delay_s=st.floats(0.0, 0.5),
    tau_s=st.floats(0.02, 0.5),
    noise=st.floats(0.0, 0.01),
    rate_hz=st.sampled_from([5.0, 10.0, 20.0, 50.0]),
)
def test_a_robot_that_follows_its_commands_has_no_unattended_sample(
    seed: int, delay_s: float, tau_s: float, noise: float, rate_hz: float
) -> None:
    """Steps at a steady command rate, answered with a delay and a first-order lag: nothing
    is flagged, whatever the rates, the delay, the lag and the noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 40.0, 1.0 / rate_hz)
    holds = rng.uniform(0.5, 4.0, 40).cumsum()
    levels = rng.choice([0.0, 0.0, 0.1, 0.3, -0.2], size=41)
    cmd = levels[np.searchsorted(holds, t)]
    dt = t[1] - t[0]
    real = np.zeros(t.size)
    lagged = levels[np.searchsorted(holds, t - delay_s)]
    for k in range(1, t.size):
        real[k] = real[k - 1] + (lagged[k] - real[k - 1]) * (1 - np.exp(-dt / tau_s))
    real += rng.normal(0.0, noise, t.size)
    found = find_unattended(_trace(real, cmd, hz=rate_hz))
    assert not found.flagged.any(), found.ranges_s


def test_fit_and_calibrate_leave_them_out_with_the_same_note(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`sysid fit` and `sysid calibrate` (on another session) leave the hand-driven stretch
    out, with agree's note."""
    real, cmd = _joystick()
    log = _write(tmp_path / "joy.mcap", real, cmd)
    other = _write(tmp_path / "joy2.mcap", np.where(cmd > 0, 0.97 * real, real), cmd)
    params, calibrated = tmp_path / "p.yaml", tmp_path / "c.yaml"
    robot = ["--robot", "turtlebot2"]
    assert main(["sysid", "fit", str(log), *robot, "-o", str(params)]) == 0
    fit_out = " ".join(capsys.readouterr().out.split())  # the terminal wraps long notes
    argv = ["sysid", "calibrate", str(params), str(other), *robot, "-o", str(calibrated)]
    assert main([*argv, "--ensemble", "4"]) == 0
    cal_out = " ".join(capsys.readouterr().out.split())
    assert fit_out.count("left out 50 samples") == 1 and "at 22.0-26.9 s;" in fit_out
    assert "left out 50 samples" in cal_out and "22.0-26.9 s" in cal_out
    assert "--keep-all keeps them" in cal_out
