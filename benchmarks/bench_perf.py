"""Headline figures: CLI start-up, agree on a 1-minute log, the pybullet loop, DepthNoise.

Run with ``.venv/bin/python benchmarks/bench_perf.py [--quick] [--only PART]`` (parts: ``cli``,
``pybullet``, ``depth``; repeatable). Every ratio alternates ours and
the baseline in one process with the same repeat count and prints min/median/max; command times
are whole processes as a user runs them, cold (empty bytecode and numba caches) and warm.

1. ``sim2real robots list`` and ``sim2real logs info LOG`` against ``python -c "import
   gymnasium"`` (target: <= 3x);
2. ``sim2real agree LOG --engine reduced`` on a 1-minute log (the first 60 s of
   ``data/demo_validate.mcap``) (target: < 0.8 s);
3. ``PybulletRobot.step`` at 10 Hz control (24 physics steps of 1/240 s each) against
   ``stepSimulation`` alone on the same robot, substeps and motion (target: >= 80 % of its
   rate): the ``stepSimulation`` calls timed inside a replay of the very torques
   ``PybulletRobot`` sets (one ``setJointMotorControlArray`` per physics step, the floor of
   any torque-level drive loop, itself a contender), then that replay with the loop's two
   state reads and with its kernel call too, which splits the loop's time per physics step;
   and the old bare reference, each control step's mean torques set once per control step
   (a ``TORQUE_CONTROL`` torque acts in one ``stepSimulation`` only, so that robot coasts
   through the other substeps: less solver work than the driven motion); wall and CPU time;
   ``sim2real agree --engine pybullet`` on the 1-minute log as the whole-command figure;
4. ``DepthNoise`` on a 640x480 float32 image against its floor, the random bits of one frame plus
   one add (target: >= 1,800 frames/s).
"""

from __future__ import annotations

import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from _timing import (
    CPU_S,
    QUICK,
    REPO,
    Stats,
    alternate,
    bench_arguments,
    command_times,
    machine,
    paired_ratios,
    record,
)

PY = sys.executable


def _minute_log(folder: Path) -> Path:
    from sim2real.logs import read_trace, write_trace

    tr = read_trace(REPO / "data" / "demo_validate.mcap")
    return write_trace(folder / "minute.mcap", tr.window(0.0, 60.0))


def bench_cli(repeats: int) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        log = _minute_log(Path(tmp))
        cmds = {
            "import gymnasium": [PY, "-c", "import gymnasium"],
            "sim2real robots list": [PY, "-m", "sim2real", "robots", "list"],
            "sim2real logs info": [PY, "-m", "sim2real", "logs", "info", str(log)],
            "sim2real agree --engine reduced (60 s log)": [
                PY, "-m", "sim2real", "agree", str(log), "--robot", "turtlebot3_burger",
                "--engine", "reduced",
            ],
            "sim2real agree --engine pybullet (60 s log)": [
                PY, "-m", "sim2real", "agree", str(log), "--robot", "turtlebot3_burger",
                "--engine", "pybullet",
            ],
        }  # fmt: skip
        res = command_times(cmds, repeats)
    print(f"1./2. whole commands, {repeats} warm runs alternated (cold: empty caches, 1 run)")
    base = res["import gymnasium"][1]
    cpu = {name: statistics.median(CPU_S[" ".join(argv)][-repeats:]) for name, argv in cmds.items()}
    for name, (cold, warm) in res.items():
        print(
            f"   {name:<44} cold {cold:6.2f} s  warm {warm.fmt(1.0, 's')}  "
            f"warm CPU {cpu[name]:.2f} s (median, user + system)"
        )
    for name in ("sim2real robots list", "sim2real logs info"):
        warm = res[name][1]
        lo, med, hi = paired_ratios(warm, base)
        print(f"   {name} / import gymnasium: {lo:.2f}/{med:.2f}/{hi:.2f}x (target <= 3x)")
        cpu_ratio = cpu[name] / cpu["import gymnasium"]
        print(f"   {name} / import gymnasium in CPU time: {cpu_ratio:.2f}x")
        record(
            "cli",
            f"`{name}` / `python -c 'import gymnasium'` (warm)",
            f"wall {med:.2f}x (min {lo:.2f}, max {hi:.2f}); CPU {cpu_ratio:.2f}x; "
            f"cold {res[name][0]:.2f} s",
            "<= 3x",
            med <= 3.0,
        )
    agree = "sim2real agree --engine reduced (60 s log)"
    cold, warm = res[agree]
    cpu_warm = warm.cpu()
    print(
        f"   agree --engine reduced, 60 s log: warm median {warm.median:.2f} s, CPU "
        f"{cpu_warm.median:.2f} s (target < 0.8 s)"
    )
    record(
        "cli",
        "`sim2real agree --engine reduced`, 1-minute log, whole process",
        f"warm {warm.median:.2f} s (min {warm.min:.2f}, max {warm.max:.2f}), CPU "
        f"{cpu_warm.median:.2f} s; cold {cold:.2f} s",
        "< 0.8 s",
        warm.median < 0.8,
    )
    pyb = "sim2real agree --engine pybullet (60 s log)"
    cold, warm = res[pyb]
    record(
        "robots",
        "`sim2real agree --engine pybullet`, 1-minute log, whole process",
        f"warm {warm.median:.2f} s (min {warm.min:.2f}, max {warm.max:.2f}), CPU "
        f"{warm.cpu().median:.2f} s; cold {cold:.2f} s",
        "-",
        None,
    )


def _recorded_torques(robot: object, cmd: np.ndarray) -> list[tuple[float, float]]:
    """The wheel torques ``PybulletRobot.step`` sets in every physics step for ``cmd``."""
    from robots._pybullet import pybullet as p

    seen: list[tuple[float, float]] = []
    real = p.setJointMotorControlArray

    def spy(*args: object, **kw: object) -> object:
        forces = kw["forces"] if "forces" in kw else args[5]
        seen.append(tuple(forces))  # type: ignore[arg-type]
        return real(*args, **kw)

    p.setJointMotorControlArray = spy
    try:
        robot.reset()  # type: ignore[attr-defined]
        for v, w in cmd:
            robot.step(float(v), float(w), 0.1)  # type: ignore[attr-defined]
    finally:
        p.setJointMotorControlArray = real
    return seen


def bench_pybullet_loop(repeats: int, control_steps: int) -> None:
    from robots import PybulletRobot, load_spec
    from robots._kernel import pybullet_substep
    from robots._pybullet import pybullet as p
    from robots._urdf import LEFT_WHEEL_JOINT, RIGHT_WHEEL_JOINT

    robot = PybulletRobot(load_spec("turtlebot3_burger"))
    c, body, wheels = robot.client, robot.body_id, (LEFT_WHEEL_JOINT, RIGHT_WHEEL_JOINT)
    substeps = round(0.1 * robot.physics_hz)
    cmd = np.random.default_rng(0).uniform(-1.0, 1.0, (control_steps, 2)) * (0.22, 2.8)
    torques = _recorded_torques(robot, cmd)
    # each control step's mean torques, set once per control step: pybullet applies a
    # TORQUE_CONTROL torque for one stepSimulation only, so the robot then coasts for the other
    # substeps (after 1 s of 0.02 N m: 0.05 m/s, against 1.17 m/s with the torque set in every
    # step) and the solver has less to do than on the driven motion
    means = [
        tuple(np.mean(torques[k * substeps : (k + 1) * substeps], axis=0).tolist())
        for k in range(control_steps)
    ]
    unused, mode = (0.0, 0.0), p.TORQUE_CONTROL
    share: list[float] = []  # stepSimulation's share of each timed replay's wall time

    def bare(per_step: list[tuple[float, ...]]) -> None:
        robot.reset()
        for forces in per_step:
            p.setJointMotorControlArray(
                body, wheels, p.TORQUE_CONTROL, forces=forces, physicsClientId=c
            )
            for _ in range(substeps):
                p.stepSimulation(physicsClientId=c)

    # positional arguments (see robots.pybullet_robot._UNUSED): the cheapest calls pybullet has
    def replayed() -> None:
        robot.reset()
        drive, step = p.setJointMotorControlArray, p.stepSimulation
        for forces in torques:
            drive(body, wheels, mode, unused, unused, forces, unused, unused, c)
            step(c)

    def bracket_s() -> float:
        """What the clock bracket around a stepSimulation call adds to it, s (median of 5)."""
        clock, runs = time.perf_counter, []
        for _ in range(5):
            inside = 0.0
            for _ in torques:
                t0 = clock()
                inside += clock() - t0
            runs.append(inside / len(torques))
        return statistics.median(runs)

    def steps_timed() -> None:
        robot.reset()
        drive, step, clock = p.setJointMotorControlArray, p.stepSimulation, time.perf_counter
        inside = 0.0
        start = clock()
        for forces in torques:
            drive(body, wheels, mode, unused, unused, forces, unused, unused, c)
            t0 = clock()
            step(c)
            inside += clock() - t0
        share.append((inside - len(torques) * bracket) / (clock() - start))

    def replayed_reading(with_kernel: bool) -> None:
        robot.reset()
        drive, step = p.setJointMotorControlArray, p.stepSimulation
        states, base = p.getJointStates, p.getBaseVelocity
        state, packed, spin, dt = np.zeros(5), robot._packed, robot._spin_inertia, robot.dt_s
        for forces in torques:
            (_, wl, _, _), (_, wr, _, _) = states(body, wheels, c)
            (vx, vy, _), (_, _, wz) = base(body, c)
            if with_kernel:  # the same work as PybulletRobot's, its torques thrown away
                pybullet_substep(state, 0.1, 0.5, wl, wr, vx, vy, wz, dt, packed, spin)
            drive(body, wheels, mode, unused, unused, forces, unused, unused, c)
            step(c)

    def ours() -> None:
        robot.reset()
        for k in range(control_steps):
            robot.step(float(cmd[k, 0]), float(cmd[k, 1]), 0.1)

    bracket = bracket_s()
    st = alternate(
        {
            "bare, once per step": lambda: bare(means),
            "stepSimulation timed": steps_timed,
            "its torques replayed": replayed,
            "replayed + 2 reads": lambda: replayed_reading(False),
            "replayed + reads + kernel": lambda: replayed_reading(True),
            "PybulletRobot.step": ours,
        },
        repeats,
    )
    robot.close()
    # stepSimulation alone on the very motion PybulletRobot drives: the stepSimulation calls'
    # share of each timed replay, less what the clock bracket itself adds (measured empty)
    timed = st.pop("stepSimulation timed")
    fractions = share[-repeats:]
    st = {
        "stepSimulation alone": Stats(
            times_s=tuple(t * f for t, f in zip(timed.times_s, fractions, strict=True)),
            cpu_s=tuple(t * f for t, f in zip(timed.cpu_s, fractions, strict=True)),
        ),
        **st,
    }
    n = control_steps * substeps
    print(f"3. pybullet loop, {control_steps} control steps x {substeps} substeps, {repeats} reps")
    print("   stepSimulation alone: its calls timed inside a replay of PybulletRobot's torques")
    print(
        f"   (the same motion: {statistics.median(fractions):.3f} of that replay's time, net of "
        f"the {bracket * 1e9:.0f} ns per step the clock reads add);"
    )
    print("   its torques replayed: one setJointMotorControlArray + stepSimulation per physics")
    print("   step (the floor of any torque-level loop), then with the two state reads, then")
    print("   with the kernel call too; bare, once per step: each control step's mean torques")
    print("   set once, as a TORQUE_CONTROL torque acts in one stepSimulation only the robot")
    print("   coasts through the other substeps (less solver work: not the same motion)")
    for name, s in st.items():
        slow, med, fast = s.rate(n)
        cslow, cmed, cfast = s.cpu().rate(n)
        print(
            f"   {name:<26} wall {slow:6.0f}/{med:6.0f}/{fast:6.0f}  CPU {cslow:6.0f}/{cmed:6.0f}/"
            f"{cfast:6.0f} physics steps/s (min/median/max); CPU {1e6 / cmed:5.2f} us/step"
        )
    ours_st = st["PybulletRobot.step"]
    figures = {}
    for name in ("stepSimulation alone", "its torques replayed", "bare, once per step"):
        base = st[name]
        lo, med, hi = paired_ratios(base, ours_st)
        clo, cmed, chi = paired_ratios(base.cpu(), ours_st.cpu())
        figures[name] = (med, cmed)
        print(
            f"   PybulletRobot / {name}: wall {lo:.2f}/{med:.2f}/{hi:.2f}, "
            f"CPU {clo:.2f}/{cmed:.2f}/{chi:.2f} (min/median/max)"
        )
    per_step = {name: s.cpu().median / n * 1e6 for name, s in st.items()}
    order = [
        ("stepSimulation", "stepSimulation alone"),
        ("the torque write", "its torques replayed"),
        ("getJointStates + getBaseVelocity", "replayed + 2 reads"),
        ("the kernel call", "replayed + reads + kernel"),
        ("the rest (per control step, loop)", "PybulletRobot.step"),
    ]
    parts, before = [], 0.0
    for what, name in order:
        parts.append(f"{what} {per_step[name] - before:.2f}")
        before = per_step[name]
    print("   CPU us per physics step, by difference of medians: " + ", ".join(parts))
    print("   target: PybulletRobot >= 0.80 of stepSimulation alone (same robot, motion, substeps)")
    med, cmed = figures["stepSimulation alone"]
    record(
        "robots",
        "`PybulletRobot.step` rate / `stepSimulation` alone (same robot, motion, 24 substeps)",
        f"wall {med:.2f}, CPU {cmed:.2f}; replaying its torques alone (one write per step) "
        f"reaches CPU {paired_ratios(st['stepSimulation alone'].cpu(), st['its torques replayed'].cpu())[1]:.2f}; "
        f"vs torques set once per control step (the robot coasts) CPU "
        f"{figures['bare, once per step'][1]:.2f}",
        ">= 0.80",
        # met only when the CPU ratio is too: a queue on a shared machine can slow the bare
        # runs' wall clock more than ours (measured: wall 0.85, CPU 0.65 in one run)
        min(med, cmed) >= 0.8,
    )


def bench_depth_noise(repeats: int, frames: int) -> None:
    import gymnasium as gym

    from randomizers import DepthNoise

    rng = np.random.default_rng(0)
    img = rng.uniform(0.3, 7.5, (480, 640)).astype(np.float32)
    img[::97, ::89] = np.nan

    class Cam(gym.Env[np.ndarray, int]):
        observation_space = gym.spaces.Box(0.0, 8.0, (480, 640), np.float32)
        action_space = gym.spaces.Discrete(1)

    env = DepthNoise(Cam(), 0.2, near_m=0.05, far_m=8.0)
    bits = np.random.default_rng(1).bit_generator

    def ours() -> None:
        for _ in range(frames):
            env.observation(img)

    def floor() -> None:
        for _ in range(frames):
            bits.random_raw(img.size // 2)
            img + img

    st = alternate({"DepthNoise": ours, "floor (bits + add)": floor}, repeats)
    print(f"4. DepthNoise 640x480 float32, {frames} frames x {repeats} reps")
    for name, s in st.items():
        slow, med, fast = s.rate(frames)
        print(f"   {name:<20} {slow:7.0f}/{med:7.0f}/{fast:7.0f} frames/s (min/median/max)")
    slow, med, fast = st["DepthNoise"].rate(frames)
    record(
        "randomizers",
        "`DepthNoise` 640x480 float32 frames/s",
        f"{med:.0f} (min {slow:.0f}, max {fast:.0f}); floor {st['floor (bits + add)'].rate(frames)[1]:.0f}",
        ">= 1,800",
        med >= 1800,
    )


#: --only choices, in the order they run.
PARTS = ("cli", "pybullet", "depth")


def main() -> None:
    only = "run only this part (repeatable), e.g. --only pybullet"
    args = bench_arguments(__doc__, fewer="repeats", parts=PARTS, only_help=only).parse_args()
    args.quick = args.quick or QUICK
    reps = 5 if args.quick else 11
    chosen = set(args.only or PARTS)
    print(f"machine: {machine()}")
    if "cli" in chosen:
        bench_cli(reps)
    if "pybullet" in chosen:
        bench_pybullet_loop(reps, control_steps=20 if args.quick else 50)
    if "depth" in chosen:
        bench_depth_noise(reps, frames=20 if args.quick else 50)


if __name__ == "__main__":
    main()
