"""Benchmark: the MuJoCo engine's replay speed and an ensemble member's cost.

- Replay: a 600 s teleop-like command stream (10 Hz, piecewise constant, stops) of a
  TurtleBot3 Burger on the exported MuJoCo robot (:meth:`sim2real.mujoco.MujocoRobot.replay`,
  240 Hz physics, 30 Hz outputs), best of ``--repeats``; the target is >= 200x real time, the
  whole command (targets, controls, samples and physics). The bare physics of the same steps
  (``mj_step`` 144 000 times) is printed beside it; the replay may cost at most 2x it.
- Ensemble member: writing another parameter set into the compiled ``MjModel``
  (:meth:`~sim2real.mujoco.MujocoRobot.set_params`) against compiling the model anew
  (``MjModel.from_xml_string``), median of ``--repeats``.

Needs the [mujoco] extra. Run: ``.venv/bin/python benchmarks/bench_mujoco.py [--repeats N]``
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time

import numpy as np
from _timing import record

from robots.mjcf import mjcf_text
from robots.spec import load_spec

ROBOT = "turtlebot3_burger"
DURATION_S = 600.0
TARGET_X = 200.0


def _commands(seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, DURATION_S, 0.1)
    k = np.searchsorted(np.cumsum(rng.uniform(0.5, 2.0, t.size)), t)
    stop = rng.random(t.size)[k] < 0.2
    v = np.where(stop, 0.0, rng.uniform(-0.1, 0.22, t.size)[k])
    w = np.where(stop, 0.0, rng.uniform(-2.0, 2.0, t.size)[k])
    return t, v, w


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args(argv)
    try:
        import mujoco

        from sim2real.mujoco import MujocoRobot
    except ImportError:
        print("skipped: mujoco is not installed (pip install 'sim2real[mujoco]')")
        return 0
    spec = load_spec(ROBOT)
    robot = MujocoRobot(spec)
    cmd, t_out = _commands(0), np.arange(0.0, DURATION_S, 1 / 30)
    robot.replay(tuple(a[:20] for a in cmd), t_out[:20])  # compile the kernels first
    replay_s, physics_s = [], []
    for _ in range(args.repeats):
        start = time.perf_counter()
        robot.replay(cmd, t_out)
        replay_s.append(time.perf_counter() - start)
        start = time.perf_counter()
        mujoco.mj_step(robot.model, robot.data, round(DURATION_S * 240))
        physics_s.append(time.perf_counter() - start)
    factor = DURATION_S / min(replay_s)
    print(
        f"replay of {DURATION_S:.0f} s: best {min(replay_s):.2f} s ({factor:.0f}x real time; "
        f"target >= {TARGET_X:.0f}x); bare physics {min(physics_s):.2f} s"
    )
    record(
        "mujoco",
        "600 s replay, x real time",
        f"{factor:.0f}",
        f">= {TARGET_X:.0f}",
        factor >= TARGET_X,
    )
    overhead = min(replay_s) / min(physics_s)  # the replay's own work beside MuJoCo's steps
    record("mujoco", "600 s replay / bare physics", f"{overhead:.2f}", "<= 2", overhead <= 2.0)
    params = spec.drive.replace(added_mass_kg=0.3, motor_gain_nms_per_rad=0.015)
    edit, build = [], []
    xml = mjcf_text(spec, params)
    for _ in range(args.repeats):
        start = time.perf_counter()
        robot.set_params(params)
        edit.append(time.perf_counter() - start)
        start = time.perf_counter()
        mujoco.MjModel.from_xml_string(xml)
        build.append(time.perf_counter() - start)
    print(
        f"ensemble member: field edit {1e3 * statistics.median(edit):.2f} ms, "
        f"recompile {1e3 * statistics.median(build):.2f} ms"
    )
    return 0 if factor >= TARGET_X else 1


if __name__ == "__main__":
    sys.exit(main())
