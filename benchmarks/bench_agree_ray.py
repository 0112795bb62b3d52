"""Fleet agreement on Ray vs serial: the whole ``sim2real agree`` command on N one-minute logs.

Run (needs the [cluster] extra, ``make train-extra``; ~3.5 min for 100 logs on 2 idle cores,
~2.7 min with ``--no-running``), then ``python results_page.py`` from ``benchmarks/``::

    .venv/bin/python benchmarks/bench_agree_ray.py                          # 100 logs, 3 repeats
    .venv/bin/python benchmarks/bench_agree_ray.py --logs 20 --repeats 1    # a quick look

Target: ``sim2real agree 'fleet/*.mcap' --ray auto`` >= 1.7x faster than the same command
without ``--ray`` on 2 cores, with identical figures.

Each side is the command a user types, run as a fresh process on the same logs (written once
into ``--folder``, default ``$TMPDIR/bench-fleet``), pybullet engine, ``--json`` output:

- ``serial``: ``sim2real agree 'DIR/*.mcap' --robot turtlebot3_burger --json serial.json``;
- ``cold Ray``: the same with ``--ray auto`` and no Ray running, so the command starts a local
  Ray and stops it again (the target's case: Ray's start-up, shutdown and imports included);
- ``running Ray`` (skip with ``--no-running``): the same joining a local Ray started beforehand
  by ``ray start --head`` (what a user who runs many commands does once);
- ``two halves``: two serial commands at once, each on every other log, with no coordination:
  the most any engine could get from these two cores in the same run.

After one untimed warm-up of each side on a few logs (file and numba caches), the sides
alternate, ``--repeats`` times each; min / median / max are printed, and the speed-up is median
serial / median Ray wall time. Every run's JSON must be byte-identical to the first serial
run's. Each run also counts the CPU seconds of every process it started, Ray's own (GCS,
raylet, agents, workers) included: this script makes itself the subreaper of its descendants
(``PR_SET_CHILD_SUBREAPER``, Linux), so orphaned Ray processes are reaped here and their CPU
counted. ``CPU cost`` = Ray CPU / serial CPU; ``CPU bound`` = serial CPU / (Ray CPU / 2) is the
most the two cores could give. On an idle machine the wall-clock speed-up is the figure.
"""

from __future__ import annotations

import argparse
import contextlib
import ctypes
import os
import shutil
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Set
from dataclasses import dataclass
from pathlib import Path

TARGET = 1.7
ROBOT = "turtlebot3_burger"
_TICK = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100
_PR_SET_CHILD_SUBREAPER = 36  # linux/prctl.h


def fleet(folder: Path, n: int) -> list[Path]:
    """``n`` one-minute synthetic sessions (written once, reused)."""
    from sim2real.cluster import write_synthetic_fleet

    folder.mkdir(parents=True, exist_ok=True)
    have = sorted(folder.glob("session_*.mcap"))
    if len(have) >= n:
        return have[:n]
    return write_synthetic_fleet(folder, n, duration_s=60.0, seed=1000)


def _proc_table() -> dict[int, tuple[str, int, float]]:
    """pid -> (command name, parent pid, its own CPU seconds, children not) from /proc."""
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
        table[int(entry)] = (name, int(f[1]), (int(f[11]) + int(f[12])) / _TICK)
    return table


def descendants(skip: Set[int] = frozenset()) -> dict[int, tuple[str, float]]:
    """Every descendant of this process (zombies too): pid -> (name, own CPU s); not ``skip``'s
    subtrees."""
    table = _proc_table()
    children: dict[int, list[int]] = {}
    for pid, (_, ppid, _) in table.items():
        children.setdefault(ppid, []).append(pid)
    out: dict[int, tuple[str, float]] = {}
    stack = [os.getpid()]
    while stack:
        for pid in children.get(stack.pop(), []):
            if pid not in skip:
                out[pid] = (table[pid][0], table[pid][2])
                stack.append(pid)
    return out


def reap() -> None:
    """Collect every exited child (orphans re-parented here included)."""
    while True:
        try:
            pid, _ = os.waitpid(-1, os.WNOHANG)
        except ChildProcessError:
            return
        if pid == 0:
            return


class CpuMeter:
    """Own CPU seconds of every process this script starts, by pid, polled every ``every_s``.

    Each process's own user + system time (not its reaped children's: a Ray raylet does not
    reap every worker, so whole-tree ``getrusage`` misses some), read while it lives; a
    process that exits between two polls loses at most its last ``every_s`` of CPU (Ray's
    processes are idle when they stop; the command itself is read as a zombie, exactly).
    """

    def __init__(self, every_s: float = 0.5) -> None:
        self.every_s = every_s
        self.start: dict[int, float] = {pid: cpu for pid, (_, cpu) in descendants().items()}
        self.seen: dict[int, tuple[str, float]] = {}

    def poll(self) -> None:
        for pid, (name, cpu) in descendants().items():
            self.seen[pid] = (name, max(cpu, self.seen.get(pid, (name, 0.0))[1]))

    def total_s(self) -> float:
        return sum(cpu - self.start.get(pid, 0.0) for pid, (_, cpu) in self.seen.items())

    def by_name(self) -> dict[str, float]:
        out: dict[str, float] = {}
        for pid, (name, cpu) in self.seen.items():
            out[name] = out.get(name, 0.0) + cpu - self.start.get(pid, 0.0)
        return out


def other_ray() -> list[int]:
    """pids of the Ray GCS servers running on this machine (``--ray auto`` would join one)."""
    return [pid for pid, (name, _, _) in _proc_table().items() if name == "gcs_server"]


@dataclass(frozen=True, kw_only=True)
class Run:
    wall_s: float
    cpu_s: float
    by_name: dict[str, float]
    load: float
    output: bytes


def run_command(
    argv: list[str] | list[list[str]],
    env: dict[str, str],
    out: Path,
    keep: Set[int] = frozenset(),
) -> Run:
    """Run one command (or several at once, a list of argv lists) to the end (and its
    orphans): wall and every process's CPU time.

    Every process this script started counts (a Ray started beforehand, ``keep``, included:
    its workers do the work of a command that joins it). ``out`` is the first command's JSON.
    """
    argvs: list[list[str]] = [argv] if isinstance(argv[0], str) else argv  # type: ignore[list-item]
    out.unlink(missing_ok=True)
    meter = CpuMeter()
    t0 = time.perf_counter()
    procs = [subprocess.Popen(a, env=env, stdout=subprocess.DEVNULL) for a in argvs]
    next_poll = 0.0
    while any(
        os.waitid(os.P_PID, p.pid, os.WEXITED | os.WNOHANG | os.WNOWAIT) is None for p in procs
    ):
        if time.perf_counter() >= next_poll:
            meter.poll()
            next_poll = time.perf_counter() + meter.every_s
        time.sleep(0.01)
    wall = time.perf_counter() - t0
    meter.poll()  # the commands are zombies now: their final CPU time
    for a, p in zip(argvs, procs, strict=True):
        if p.wait() != 0:
            raise subprocess.CalledProcessError(p.returncode, a)
    quiet(keep, meter)
    return Run(
        wall_s=wall,
        cpu_s=meter.total_s(),
        by_name=meter.by_name(),
        load=os.getloadavg()[0],
        output=out.read_bytes(),
    )


def quiet(keep: Set[int] = frozenset(), meter: CpuMeter | None = None) -> None:
    """Wait until every process this script started has exited, but ``keep``'s."""
    deadline = time.monotonic() + 20.0  # a local Ray's workers exit after its raylet
    while time.monotonic() < deadline and descendants(keep):
        if meter is not None:
            meter.poll()
        reap()
        time.sleep(0.05)


def start_running_ray(env: dict[str, str], temp: Path) -> tuple[str, set[int]]:
    """``ray start --head`` (own temp folder, free port): its address and its processes."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    ray_bin = str(Path(sys.executable).with_name("ray"))
    subprocess.run(
        [
            ray_bin,
            "start",
            "--head",
            f"--port={port}",
            f"--temp-dir={temp}",
            "--node-ip-address=127.0.0.1",  # this machine only: it runs without a token
            "--include-dashboard=false",
            "--disable-usage-stats",
        ],
        check=True,
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    reap()
    return f"127.0.0.1:{port}", set(descendants())


def stop_running_ray() -> None:
    """Stop the Ray of :func:`start_running_ray` (only it: ``ray stop`` would stop every Ray)."""
    for sig, wait_s in ((signal.SIGTERM, 5.0), (signal.SIGKILL, 5.0)):
        for pid in descendants():
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, sig)
        deadline = time.monotonic() + wait_s
        while time.monotonic() < deadline and descendants():
            reap()
            time.sleep(0.05)


def mmm(xs: list[float]) -> str:
    return f"{min(xs):6.1f} / {statistics.median(xs):6.1f} / {max(xs):6.1f} s"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    ap.add_argument("--logs", type=int, default=100, help="one-minute logs (default 100)")
    ap.add_argument("--repeats", type=int, default=3, help="timed runs per side (default 3)")
    ap.add_argument("--engine", default="pybullet", choices=("pybullet", "reduced"))
    ap.add_argument(
        "--folder",
        type=Path,
        default=Path(tempfile.gettempdir()) / "bench-fleet",
        help="fleet cache (default $TMPDIR/bench-fleet)",
    )
    ap.add_argument(
        "--no-running", action="store_true", help="skip the side with a Ray started beforehand"
    )
    args = ap.parse_args(argv)
    if not sys.platform.startswith("linux"):
        print("bench_agree_ray: skipped, counts CPU through /proc and prctl (Linux only)")
        return 0
    try:
        import ray  # noqa: F401
    except ImportError:
        print("bench_agree_ray: skipped, needs the [cluster] extra (make train-extra)")
        return 0
    ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0)
    logs = fleet(args.folder, args.logs)
    work = Path(tempfile.mkdtemp(prefix="bench-agree-ray-"))
    pattern = str(work / "fleet" / "*.mcap")
    (work / "fleet").mkdir()
    for p in logs:
        (work / "fleet" / p.name).symlink_to(p.resolve())
    warm_dir = work / "warm"
    warm_dir.mkdir()
    for p in logs[:4]:
        (warm_dir / p.name).symlink_to(p.resolve())
    for half in ("a", "b"):  # every other log, for the two-processes baseline
        (work / half).mkdir()
    for i, p in enumerate(logs):
        (work / ("a" if i % 2 == 0 else "b") / p.name).symlink_to(p.resolve())
    sim2real = str(Path(sys.executable).with_name("sim2real"))
    env = {k: v for k, v in os.environ.items() if k != "RAY_ADDRESS"}
    env.setdefault("RAY_USAGE_STATS_ENABLED", "0")
    env["RAY_worker_niceness"] = "0"  # a `ray start` Ray's workers at the command's priority

    def command(side: str, glob: str, out: Path) -> list[str]:
        cmd = [sim2real, "agree", glob, "--robot", ROBOT, "--engine", args.engine]
        return cmd + ["--json", str(out)] + ([] if side == "serial" else ["--ray", "auto"])

    sides = ["serial", "cold Ray", "two halves"] + ([] if args.no_running else ["running Ray"])

    def one(side: str, glob: str, out: Path) -> Run:
        if side == "cold Ray":
            _wait_for_no_other_ray()
        if side == "two halves":  # two serial commands at once, each on every other log
            folder = Path(glob).parent
            halves = [work / "a", work / "b"] if glob == pattern else [folder, folder]
            argvs = [
                command("serial", str(h / "*.mcap"), out.with_name(f"{out.stem}_{i}.json"))
                for i, h in enumerate(halves)
            ]
            return run_command(argvs, env, out.with_name(f"{out.stem}_0.json"))
        if side != "running Ray":
            return run_command(command(side, glob, out), env, out)
        # not timed; without token authentication (Ray's default with ~/.ray/auth_token made a
        # `ray start --temp-dir` cluster refuse the command's connection for seconds)
        local = {**env, "RAY_AUTH_MODE": "disabled"}
        address, keep = start_running_ray(local, work / "ray")
        try:
            argv = command(side, glob, out)
            return run_command(argv, {**local, "RAY_ADDRESS": address}, out, keep)
        finally:
            stop_running_ray()

    try:
        for side in sides:  # untimed: file cache, numba cache, pyc
            one(side, str(warm_dir / "*.mcap"), work / "w.json")
        runs: dict[str, list[Run]] = {side: [] for side in sides}
        for i in range(args.repeats):
            for side in sides if i % 2 == 0 else sides[::-1]:
                run = one(side, pattern, work / f"{side.split()[0]}.json")
                runs[side].append(run)
                print(
                    f"{side:11s} wall {run.wall_s:6.1f} s  CPU {run.cpu_s:6.1f} s  "
                    f"(load {run.load:.1f})",
                    flush=True,
                )
    finally:
        stop_running_ray()
        shutil.rmtree(work, ignore_errors=True)
    return report(args, len(logs), runs)


def _wait_for_no_other_ray() -> None:
    """A cold run needs no other Ray on the machine (``--ray auto`` would join it)."""
    deadline = time.monotonic() + 120.0
    while (others := other_ray()) and time.monotonic() < deadline:
        print(f"  (another Ray is running here, GCS pid {others}: waiting)", flush=True)
        time.sleep(5.0)
    if others:
        print(f"  WARNING: another Ray (GCS pid {others}) is running: this run joins it")


def report(args: argparse.Namespace, n: int, runs: dict[str, list[Run]]) -> int:
    reference = runs["serial"][0].output
    identical = all(
        r.output == reference for side, rs in runs.items() if side != "two halves" for r in rs
    )
    print(
        f"{n} one-minute logs, engine {args.engine}, whole `sim2real agree` command, "
        f"{args.repeats} alternated repeats per side, {os.cpu_count()} cores"
    )
    wall = {k: statistics.median(r.wall_s for r in rs) for k, rs in runs.items()}
    cpu = {k: statistics.median(r.cpu_s for r in rs) for k, rs in runs.items()}
    for side, rs in runs.items():
        print(
            f"  {side:11s} wall min/median/max {mmm([r.wall_s for r in rs])}   "
            f"CPU {mmm([r.cpu_s for r in rs])}   load {mmm([r.load for r in rs])[:-2]}"
        )
    for side, rs in runs.items():
        if side != "serial":
            parts = sorted(rs[-1].by_name.items(), key=lambda kv: -kv[1])
            shown = ", ".join(f"{name} {cpu:.1f}" for name, cpu in parts if cpu >= 0.05)
            print(f"  CPU s by process, last {side} run: {shown}")
    figures = {}
    for side in runs:
        if side == "serial":
            continue
        speedup = wall["serial"] / wall[side]
        bound = cpu["serial"] / (cpu[side] / 2)
        figures[side] = (speedup, bound)
        print(
            f"{side}: wall-clock speed-up (median serial / median {side}) {speedup:.2f}x "
            f"(target >= {TARGET}x); CPU cost {cpu[side] / cpu['serial']:.2f}x serial, "
            f"CPU bound on 2 cores {bound:.2f}x"
        )
    if "two halves" in figures:
        ceiling = figures["two halves"][0]
        print(
            f"two halves = the most any engine gets from these 2 cores in this run (two serial "
            f"commands at once, no coordination): {ceiling:.2f}x; cold Ray reaches "
            f"{figures['cold Ray'][0] / ceiling:.0%} of it"
        )
    print(f"JSON byte-identical across all runs (Ray and serial): {identical}")
    _record(n, figures, identical)
    return 0 if identical else 1


def _record(n: int, figures: dict[str, tuple[float, float]], identical: bool) -> None:
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    try:
        from _timing import record
    except ImportError:
        return
    load = os.getloadavg()[0]
    speedup, bound = figures["cold Ray"]
    value = f"{speedup:.2f}x wall (load {load:.1f}), CPU bound {bound:.2f}x"
    if "running Ray" in figures:
        value += f"; Ray already running {figures['running Ray'][0]:.2f}x"
    value += "; figures identical" if identical else "; FIGURES DIFFER"
    record(
        "agree --ray",
        f"whole command, {n} one-minute logs, --ray auto (cold local Ray) vs serial",
        value,
        f">= {TARGET}x on 2 cores, identical figures",
        identical and speedup >= TARGET,
    )


if __name__ == "__main__":
    sys.exit(main())
