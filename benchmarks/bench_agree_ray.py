"""Fleet agreement on Ray vs serial: N one-minute logs through ``agree``, same figures.

Run (needs the [cluster] extra; ~4 min for 100 logs on 2 idle cores)::

    .venv/bin/python benchmarks/bench_agree_ray.py --logs 100 --repeats 3
    .venv/bin/python benchmarks/bench_agree_ray.py --logs 20 --repeats 2   # quick look

Target (issue 15): ``sim2real agree 'fleet/*.mcap' --ray auto`` >= 1.7x faster than the serial
path on 2 cores, with identical figures.

Both sides run :func:`sim2real.cluster.agree_many` (what ``agree`` with several logs runs) on the
same configs (pybullet engine, spec parameters): serial is the in-process loop, Ray the guided
batches of :func:`sim2real.cluster.map_tasks` on a local Ray started once before the timing, as
``ray start --head`` on a workstation gives (its start-up time is printed apart; a cold
``agree --ray auto`` with no Ray running pays it once). One untimed warm-up pass per side
imports the libraries and loads the numba kernels in the driver and in every Ray worker (the
per-worker cost is printed). Then the sides alternate (serial, Ray, Ray, serial, ...),
``--repeats`` times each; min / median / max are printed and the speed-up is median serial /
median Ray wall time.

Wall time on a shared machine measures the queue as much as the work, so each run also counts
CPU seconds: the serial side's process, and for Ray the driver plus every process Ray started
under it (GCS, raylet, agents, workers; read from ``/proc``, Linux only). From those,
``CPU efficiency`` = serial CPU (its main thread's, without the idle Ray client threads of
the driver) / Ray CPU, and the wall time Ray would take on ``k`` free cores
is at least max(Ray CPU / k, busiest worker's CPU): ``projected speed-up on k free cores`` =
serial CPU / that bound (serial on an idle core takes its CPU time). On an idle machine the
measured wall-clock speed-up is the figure; on a loaded one the projection is: Linux schedules
by session (``sched_autogroup``) and the Ray workers share the driver's session, so under load
the whole benchmark gets one session's share of the CPU however many processes it runs.
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import statistics
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from sim2real.cluster import agree_many, connect, write_synthetic_fleet
from sim2real.study import StudyConfig

TARGET = 1.7
_TICK = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100


def fleet(folder: Path, n: int) -> list[Path]:
    """``n`` one-minute synthetic sessions (written once, reused)."""
    folder.mkdir(parents=True, exist_ok=True)
    have = sorted(folder.glob("session_*.mcap"))
    if len(have) >= n:
        return have[:n]
    return write_synthetic_fleet(folder, n, duration_s=60.0, seed=1000)


def descendant_cpu() -> dict[int, tuple[str, float]]:
    """CPU seconds (user + system, incl. reaped children) of every descendant process, by pid."""
    table: dict[int, tuple[str, int, float]] = {}
    for entry in os.listdir("/proc") if os.path.isdir("/proc") else ():
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat", encoding="utf-8") as fh:
                text = fh.read()
        except OSError:
            continue
        name = text[text.index("(") + 1 : text.rindex(")")]
        f = text[text.rindex(")") + 2 :].split()
        cpu = (int(f[11]) + int(f[12]) + int(f[13]) + int(f[14])) / _TICK
        table[int(entry)] = (name, int(f[1]), cpu)
    children: dict[int, list[int]] = {}
    for pid, (_, ppid, _) in table.items():
        children.setdefault(ppid, []).append(pid)
    out: dict[int, tuple[str, float]] = {}
    stack = [os.getpid()]
    while stack:
        for pid in children.get(stack.pop(), []):
            out[pid] = (table[pid][0], table[pid][2])
            stack.append(pid)
    return out


@dataclass(frozen=True, kw_only=True)
class Run:
    wall_s: float
    cpu_s: float  # driver + descendants
    thread_s: float  # the driver's main thread only (serial: the work, without Ray's threads)
    busiest_s: float  # the descendant with the most CPU in this run (a Ray worker)
    figures: list[object]


def timed(configs: list[StudyConfig], address: str | None) -> Run:
    before = descendant_cpu()
    c0, t0, m0 = time.process_time(), time.perf_counter(), time.thread_time()
    out = agree_many(configs, address=address)
    wall, driver = time.perf_counter() - t0, time.process_time() - c0
    main_thread = time.thread_time() - m0
    after = descendant_cpu()
    deltas = [cpu - before.get(pid, (name, 0.0))[1] for pid, (name, cpu) in after.items()]
    return Run(
        wall_s=wall,
        cpu_s=driver + sum(deltas),
        thread_s=main_thread,
        busiest_s=max(deltas, default=0.0),
        figures=[fig for fig, _ in out],
    )


def mmm(xs: list[float]) -> str:
    return f"{min(xs):7.1f} / {statistics.median(xs):7.1f} / {max(xs):7.1f} s"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--logs", type=int, default=100, help="one-minute logs (default 100)")
    ap.add_argument("--repeats", type=int, default=3, help="timed runs per side (default 3)")
    ap.add_argument("--engine", default="pybullet", choices=("pybullet", "reduced"))
    ap.add_argument("--folder", type=Path, default=Path("bench-fleet"), help="fleet cache")
    ap.add_argument(
        "--address",
        default=None,
        help="an existing Ray cluster (HOST:PORT or auto); default: start a local Ray here",
    )
    args = ap.parse_args(argv)
    try:
        import ray
    except ImportError:
        print("bench_agree_ray: skipped, needs the [cluster] extra (make train-extra)")
        return 0
    logs = fleet(args.folder, args.logs)
    configs = [StudyConfig(log=str(p), robot="turtlebot3_burger", engine=args.engine) for p in logs]
    t0 = time.perf_counter()
    if args.address is None:
        os.environ.pop("RAY_ADDRESS", None)
        os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
        # workers at the driver's priority, as sim2real.cluster.connect starts a local Ray
        os.environ.setdefault("RAY_worker_niceness", str(os.nice(0)))
        ray.init(include_dashboard=False, logging_level="ERROR")
    else:
        connect(args.address)
    startup_s = time.perf_counter() - t0
    address = "auto" if args.address is None else args.address
    cpus = int(ray.cluster_resources().get("CPU", 0))
    runs: dict[str, list[Run]] = {"serial": [], "ray": []}
    try:
        warm_serial = timed(configs[:2], None)
        warm_ray = timed(configs[: 2 * cpus], address)
        print(
            f"warm-up (untimed): serial 2 logs {warm_serial.cpu_s:.1f} s CPU; Ray {2 * cpus} logs "
            f"{warm_ray.cpu_s:.1f} s CPU (busiest worker {warm_ray.busiest_s:.1f} s)",
            flush=True,
        )
        for i in range(args.repeats):
            for side in ("serial", "ray") if i % 2 == 0 else ("ray", "serial"):
                run = timed(configs, None if side == "serial" else address)
                runs[side].append(run)
                print(
                    f"{side:6s} wall {run.wall_s:6.1f} s  CPU {run.cpu_s:6.1f} s  "
                    f"(load {os.getloadavg()[0]:.1f})",
                    flush=True,
                )
    finally:
        ray.shutdown()
    reference = runs["serial"][0].figures
    identical = all(r.figures == reference for rs in runs.values() for r in rs)
    wall = {k: [r.wall_s for r in rs] for k, rs in runs.items()}
    cpu = {k: [r.cpu_s for r in rs] for k, rs in runs.items()}
    print(
        f"{len(logs)} one-minute logs, engine {args.engine}, Ray with {cpus} CPUs (start-up "
        f"{startup_s:.1f} s, not in the timings), {args.repeats} alternated repeats per side"
    )
    for side in runs:
        print(f"  {side:6s} wall min/median/max {mmm(wall[side])}   CPU {mmm(cpu[side])}")
    speedup = statistics.median(wall["serial"]) / statistics.median(wall["ray"])
    print(f"wall-clock speed-up (median serial / median Ray): {speedup:.2f}x (target >= {TARGET}x)")
    # the serial work is the main thread's: the driver's Ray threads (idle polling) are not it
    serial_cpu = statistics.median([r.thread_s for r in runs["serial"]])
    ray_cpu = statistics.median(cpu["ray"])
    busiest = statistics.median([r.busiest_s for r in runs["ray"]])
    projected = None
    if args.address is None and busiest > 0:  # Ray's processes are this driver's children
        efficiency = serial_cpu / ray_cpu
        bound = max(ray_cpu / cpus, busiest)
        projected = serial_cpu / bound
        print(
            f"CPU efficiency (serial main-thread CPU {serial_cpu:.1f} s / Ray CPU incl. driver "
            f"and Ray's own processes {ray_cpu:.1f} s): {efficiency:.2f}; busiest worker "
            f"{busiest:.1f} s"
        )
        print(
            f"projected speed-up on {cpus} free cores: serial CPU / max(Ray CPU / {cpus}, "
            f"busiest worker) = {projected:.2f}x"
        )
    else:
        print("CPU of the Ray processes not visible (an external cluster): no projection")
    print(f"figures identical across all runs: {identical}")
    _record(len(logs), cpus, speedup, projected, identical)
    return 0 if identical else 1


def _record(n: int, cpus: int, speedup: float, projected: float | None, identical: bool) -> None:
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    try:
        from _timing import record
    except ImportError:
        return
    load = os.getloadavg()[0]
    value = f"{speedup:.2f}x wall (load {load:.1f})"
    if projected is not None:
        value += f"; {projected:.2f}x projected from CPU time"
    value += "; figures identical" if identical else "; FIGURES DIFFER"
    met = identical and speedup >= TARGET
    record(
        "agree --ray",
        f"{n} one-minute logs, Ray ({cpus} CPUs) vs serial",
        value,
        f">= {TARGET}x on 2 cores, identical figures",
        met,
    )


if __name__ == "__main__":
    sys.exit(main())
