"""Benchmark: a log's odometry noise from its high-frequency part, against what is known.

:func:`sysid.hfnoise.highfreq_noise` measures a log's noise without held commands. It is
checked here against the two references there are:

- plant logs of known sensor noise (the skid plant: white encoder-v and gyro noise) under a
  controller's commands at 10 Hz that never stay, with and without a jitter at every message;
- real logs of the development set that hold commands (``../shared/realdata``, skipped when
  absent), against :func:`sysid.steady.steady_noise`: on the same held samples, and on every
  moving sample (what a log that never holds a command offers). The logs that never hold one
  get the high-frequency estimate alone. The TurtleBot3's yaw rate comes from its IMU, read as
  a velocity: there the scatter under held commands is slower than the odometry period and
  the high-frequency estimate sees a third of it. Beside them, :func:`sysid.hfnoise.response_noise`
  on every moving sample against the spec defaults' replay (a model no fit tuned to the log),
  with the held-command estimate of v while driving (:func:`sysid.steady.motion_noise`) it is
  compared with.

Run: ``python benchmarks/bench_hfnoise.py`` (a few seconds).
"""

from __future__ import annotations

import math
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
REALDATA = REPO.parent / "shared" / "realdata"


def _controller(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    at = np.floor(t / 0.1) * 0.1
    return 0.2 + 0.1 * np.sin(0.3 * at), 0.5 * np.sin(0.5 * at + 1.0)


def plants() -> None:
    from sim2real.plants.skid import husky_like, run_skid_plant
    from sysid.hfnoise import highfreq_noise

    p = husky_like()
    print("## skid plant (v noise 0.005 m/s, gyro 0.01 rad/s, 50 Hz), commands at 10 Hz")
    print("| command jitter (x top speed) | seed | v / known | w / known |")
    print("|---|---|---|---|")
    for jitter in (0.0, 0.02, 0.05):
        for seed in range(3):
            rng = np.random.default_rng(seed)
            t = np.arange(0.0, 60.0, 0.1)
            cv, cw = _controller(t)
            cv = np.clip(cv + jitter * p.max_v_mps * rng.standard_normal(t.size), 0, None)
            cw = cw + jitter * p.max_w_radps * rng.standard_normal(t.size)
            trace = run_skid_plant(p, t, cv, cw, duration_s=60.0, rng=rng)
            mv, mw = trace.cmd_at_meas()
            own = highfreq_noise(trace.meas_t_s, mv, mw, trace.meas_v, trace.meas_w)
            print(
                f"| {jitter:g} | {seed} | {own.std_v_mps / p.v_noise_mps:.2f} |"
                f" {own.std_w_radps / p.gyro_noise_radps:.2f} |"
            )


def _held_over(t: np.ndarray, cv: np.ndarray, cw: np.ndarray, after_s: float) -> np.ndarray:
    change = np.ones(t.size, dtype=bool)
    change[1:] = (np.diff(cv) != 0) | (np.diff(cw) != 0)
    last = np.maximum.accumulate(np.where(change, np.arange(t.size), 0))
    return t - t[last] > after_s


def _fmt(v: float, w: float) -> str:
    return "-" if math.isnan(v) else f"{1000 * v:.1f} / {1000 * w:.1f}"


def real() -> None:
    from robots.spec import load_spec
    from sim2real.agreement.replay import replay
    from sim2real.logs import read_for_robot
    from sysid.hfnoise import highfreq_noise, log_pose, response_noise
    from sysid.steady import STEADY_AFTER_S, motion_noise, steady_noise

    with tempfile.TemporaryDirectory() as tmp:
        neato = Path(tmp) / "neato.yaml"
        subprocess.run(
            [sys.executable, "-m", "sim2real", "robots", "new", "neato", "--wheel-separation",
             "0.248", "--max-speed", "0.3", "-o", str(neato)],
            check=True, capture_output=True,
        )  # fmt: skip
        specs = {"neato": load_spec(str(neato)), "tb3wp": load_spec("turtlebot3_waffle_pi")}
    print("\n## real logs: noise v (mm/s) / w (mrad/s)")
    print(
        "| log | held-command estimate (samples) | HF on the held samples | HF, every moving |"
        " held, v while driving | response, every moving |"
    )
    print("|---|---|---|---|---|---|")
    for name in sorted(p.name for p in REALDATA.glob("*.mcap")):
        trace, _ = read_for_robot(REALDATA / name, specs[name.split("_")[0]])
        t = trace.meas_t_s
        cv, cw = trace.cmd_at_meas()
        held = steady_noise(t, cv, cw, trace.meas_v, trace.meas_w)
        kw = {"measurement": trace.measurement, "pose": log_pose(trace)}
        on_held = _held_over(t, cv, cw, STEADY_AFTER_S)
        same = highfreq_noise(
            t, np.where(on_held, cv, 0), np.where(on_held, cw, 0), trace.meas_v, trace.meas_w,
            **kw,
        )  # fmt: skip
        every = highfreq_noise(t, cv, cw, trace.meas_v, trace.meas_w, **kw)
        # the spec defaults' replay: a model of the drive no fit tuned to this log
        spec = specs[name.split("_")[0]]
        sim = replay(trace, robot=spec, engine="reduced", odom_v_window_s=0.05)
        response = response_noise(
            t, cv, cw, trace.meas_v, trace.meas_w, (sim.v, sim.w), **kw
        )  # fmt: skip
        driving = motion_noise(t, cv, cw, trace.meas_v, trace.meas_w)[0]
        print(
            f"| {name[:40]} | {_fmt(held.std_v_mps, held.std_w_radps)} ({held.n_samples}) |"
            f" {_fmt(same.std_v_mps, same.std_w_radps)} |"
            f" {_fmt(every.std_v_mps, every.std_w_radps)} ({every.n_samples}) |"
            f" {_fmt(driving.std_v_mps, held.std_w_radps)} |"
            f" {_fmt(response.std_v_mps, response.std_w_radps)} ({response.n_samples}) |"
        )


if __name__ == "__main__":
    plants()
    if REALDATA.is_dir():
        real()
    else:
        print(f"\n{REALDATA} is absent: real logs skipped")
