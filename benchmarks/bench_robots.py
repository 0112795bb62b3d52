"""Benchmark of the robot models: pybullet robot, sensors, and the reduced model against it.

Run with ``.venv/bin/python benchmarks/bench_robots.py [--robot NAME] [--seconds S]``.
Prints:

- pybullet robot (240 Hz physics) stepped at 10 Hz and 30 Hz control: control steps/s and
  real-time factor (simulated s per wall-clock s);
- lidar cost per scan (one ``rayTestBatch`` of the spec's beams; 360 for the TurtleBot3s);
- depth render cost per frame at 64x48, 160x120 and 640x480 (TinyRenderer, DIRECT mode);
- the reduced model measured in the same run: ``ReducedDrive.step`` at the same control rates
  and ``simulate`` on the whole command log, with the speed-up over pybullet (target >= 100x).

Every figure is the median of 5 repeats (2 with ``BENCH_QUICK=1``), the contenders alternated
in one process (``_timing.alternate``); ratios print min/median/max. The log is 20 s long in
both modes (``--seconds``).
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from typing import Any

import numpy as np
from _timing import QUICK, alternate, paired_ratios, record

from robots import DepthCamera, Lidar, PybulletRobot, ReducedDrive, load_spec, simulate
from robots.spec import CameraSpec, RobotSpec
from robots.world import add_box, add_cylinder

#: Alternated repeats of every timing (``BENCH_QUICK=1``: 2).
REPEATS = 2 if QUICK else 5


def _commands(spec: RobotSpec, n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    v = np.repeat(rng.uniform(-1.0, 1.0, n // 10 + 1), 10)[:n] * spec.max_v_mps
    w = np.repeat(rng.uniform(-1.0, 1.0, n // 10 + 1), 10)[:n] * spec.max_w_radps
    return v, w


def _per_call(fn: Callable[[], object], calls: int) -> float:
    """Median seconds per call over :data:`REPEATS` timed batches of ``calls`` calls."""
    st = alternate({"f": lambda: [fn() for _ in range(calls)]}, REPEATS)
    return st["f"].median / calls


def _obstacles(client: int) -> None:
    rng = np.random.default_rng(1)
    for _ in range(10):
        x, y = rng.uniform(-3.0, 3.0, 2)
        if math.hypot(x, y) > 0.6:
            add_box(client, (x, y, 0.5), (0.2, 0.2, 0.5))
    for _ in range(10):
        x, y = rng.uniform(-3.0, 3.0, 2)
        if math.hypot(x, y) > 0.6:
            add_cylinder(client, (x, y, 0.5), 0.15, 1.0)


def _driven(
    base: PybulletRobot | ReducedDrive, v: np.ndarray, w: np.ndarray, dt: float
) -> Callable[[], None]:
    """One timed run: reset ``base``, then step it through the commands (v, w) every ``dt`` s."""

    def run() -> None:
        base.reset()
        for a, b in zip(v, w, strict=True):
            base.step(float(a), float(b), dt)

    return run


def bench_drive(spec: RobotSpec, seconds: float) -> None:
    print(f"robot {spec.name}, {seconds:g} s of random steps and arcs per rate")
    print(
        f"{'control':>8} {'pybullet steps/s':>17} {'RTF':>7} {'reduced steps/s':>16} "
        f"{'RTF':>8} {'ratio':>7}"
    )
    for rate in (10.0, 30.0):
        dt = 1.0 / rate
        n = round(seconds * rate)
        v, w = _commands(spec, n)
        robot = PybulletRobot(spec)
        drive = ReducedDrive(spec.drive, spec.geometry)
        drive.step(0.0, 0.0, dt)  # compile
        runs = {"pybullet": _driven(robot, v, w, dt), "reduced": _driven(drive, v, w, dt)}
        st = alternate(runs, REPEATS)
        robot.close()
        t_pb, t_red = st["pybullet"].median, st["reduced"].median
        lo, med, hi = paired_ratios(st["pybullet"], st["reduced"])
        print(
            f"{rate:6.0f}Hz {n / t_pb:17.0f} {seconds / t_pb:7.1f} {n / t_red:16.0f} "
            f"{seconds / t_red:8.1f} {med:6.0f}x (min {lo:.0f}, max {hi:.0f})"
        )
    # whole-log simulation (what sysid calls thousands of times)
    n = round(seconds * 10)
    v, w = _commands(spec, n)
    cmd_t = 0.1 * np.arange(n)
    t_out = np.arange(0.0, seconds, 1.0 / 30.0)
    kw: dict[str, Any] = {"cmd_t_s": cmd_t, "cmd_v": v, "cmd_w": w, "t_out_s": t_out}
    simulate(spec.drive, spec.geometry, **kw)  # compile
    robot = PybulletRobot(spec)
    st = alternate(
        {
            "replay": lambda: robot.replay(**kw),
            "numba": lambda: simulate(spec.drive, spec.geometry, **kw),
            "python": lambda: simulate(spec.drive, spec.geometry, python=True, **kw),
        },
        REPEATS,
    )
    robot.close()
    t_rep, t_sim, t_py = (st[k].median for k in ("replay", "numba", "python"))
    print(
        f"whole log ({seconds:g} s, 10 Hz commands, 30 Hz outputs), medians of {REPEATS} alternated:"
    )
    print(f"  PybulletRobot.replay     {t_rep * 1e3:9.2f} ms   (RTF {seconds / t_rep:8.1f})")
    print(
        f"  simulate (numba)         {t_sim * 1e3:9.3f} ms   (RTF {seconds / t_sim:8.0f}) "
        f"-> {t_rep / t_sim:,.0f}x faster than pybullet"
    )
    print(f"  simulate (plain Python)  {t_py * 1e3:9.2f} ms   -> numba {t_py / t_sim:,.0f}x faster")
    lo, med, hi = paired_ratios(st["replay"], st["numba"])
    record(
        "robots",
        f"reduced `simulate` vs `PybulletRobot.replay`, {seconds:g} s log",
        f"{med:,.0f}x faster (min {lo:,.0f}, max {hi:,.0f})",
        ">= 100x",
        med >= 100,
    )


def bench_sensors(spec: RobotSpec) -> None:
    robot = PybulletRobot(spec)
    _obstacles(robot.client)
    lidar = Lidar(spec.lidar, robot)
    lidar.scan()
    t = _per_call(lidar.scan, 100)
    print(
        f"lidar ({spec.lidar.beams} beams, 20 obstacles): {t * 1e3:.3f} ms per scan "
        f"({1 / t:,.0f} scans/s)"
    )
    cam_spec = spec.depth_camera or CameraSpec(
        width=640,
        height=480,
        hfov_deg=60.0,
        near_m=0.05,
        far_m=8.0,
        xyz_m=(0.0, 0.0, 0.3),
        rpy_rad=(0.0, 0.0, 0.0),
        rate_hz=30.0,
    )
    for width, height in ((64, 48), (160, 120), (640, 480)):
        cam = DepthCamera(cam_spec, robot, width=width, height=height)
        cam.render()
        t = _per_call(cam.render, 20 if width < 640 else 5)
        print(f"depth {width}x{height}: {t * 1e3:8.2f} ms per frame ({1 / t:7.1f} frames/s)")
    robot.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", default="turtlebot3_burger")
    # 20 s in the quick run too: on a 5 s log simulate's fixed cost per call (~0.15 ms of
    # numba dispatch and array set-up) is half its time, and the ratio measured that instead
    # (80-100x on 5 s, 173x on 20 s, same machine and minute)
    parser.add_argument("--seconds", type=float, default=20.0)
    args = parser.parse_args()
    spec = load_spec(args.robot)
    bench_drive(spec, args.seconds)
    bench_sensors(load_spec("turtlebot3_waffle_pi") if spec.depth_camera is None else spec)


if __name__ == "__main__":
    main()
