"""Decode speed and memory: sim2real.logs streaming bulk reader vs mcap-ros2-support.

Run: ``.venv/bin/python benchmarks/bench_decode.py [--quick]``.

Both sides go from the file on disk to numpy arrays of the same fields (stamps or log times,
v, w and, for Odometry, x, y and the quaternion):

- ours: :func:`sim2real.logs.read_trace` (stream the file chunk by chunk, check the CRCs the
  file has, locate messages through the MessageIndex records, bulk CDR decode per chunk,
  sort/clean, pose-velocity check, build the Trace; the file's SHA-256 is *not* computed: it
  is computed only where a command writes it);
- baseline: ``mcap.reader.make_reader(..., decoder_factories=[mcap_ros2 DecoderFactory()])``
  and ``iter_decoded_messages(topics=...)``, reading the fields of each decoded object into
  lists, then numpy arrays.

Figures, each with min/median/max over repeats that alternate ours and the baseline in one
process with the same repeat count (``_timing.alternate``):

1. in process, on a generated ROS 2 log and on the real logs in ../shared/realdata: wall time
   and CPU time (``time.process_time``) of each side and their paired ratios (target >= 20x on
   the real logs). The machine may be shared (the CPU ratio is the steadier one when loaded);
2. whole process (python start-up and imports included), cold and warm, on the real logs:
   wall and CPU (``_timing.command_times``; target >= 2x), beside the floor
   ``python -c "import numpy"``: on logs this small no reader can beat the floor by much, so
   the floor's ratio is printed as the best possible. "Warm" means cached bytecode, as for an
   installed package (``PYTHONDONTWRITEBYTECODE`` is dropped);
3. peak memory of a decode of a large generated log (odometry-heavy, zstd chunks), each side in
   its own process: tracemalloc peak and VmHWM growth over the process after imports, against
   the bound 2 x (output arrays + largest chunk), where the largest chunk counts its
   compressed record and its decompressed records (both are held while it is decoded).
"""

from __future__ import annotations

import json
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from _timing import CPU_S, Stats, alternate, command_times, paired_ratios, record

REALDATA = Path(__file__).resolve().parents[1].parent / "shared" / "realdata"
T0_NS = 1_700_000_000 * 10**9
REAL_LOGS = ("tb3wp_drexel_goal.mcap", "neato_olin2018_teleop.mcap")


def _make_log(path: Path, n_odom: int = 50_000, n_cmd: int = 20_000) -> Path:
    from sim2real.logs import write_velocity_log

    rng = np.random.default_rng(0)
    odom_t = T0_NS + np.arange(n_odom, dtype=np.int64) * 20_000_000
    cmd_t = T0_NS + np.arange(n_cmd, dtype=np.int64) * 50_000_000 + 1_000
    return write_velocity_log(
        path,
        cmd_t_ns=cmd_t,
        cmd_v=rng.uniform(-0.2, 0.2, n_cmd),
        cmd_w=rng.uniform(-1, 1, n_cmd),
        meas_t_ns=odom_t,
        meas_v=rng.normal(0.1, 0.05, n_odom),
        meas_w=rng.normal(0, 0.3, n_odom),
        meas_log_t_ns=odom_t + rng.integers(1_000_000, 5_000_000, n_odom),
        odom_frame_id="odom",
        base_frame_id="base_footprint",
    )


def _ours(path: Path) -> int:
    from sim2real.logs import read_trace

    tr = read_trace(path)
    return tr.meta.cmd_count + tr.meta.meas_count


def _baseline(path: Path, cmd_topic: str = "/cmd_vel", odom_topic: str = "/odom") -> int:
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    cmd: list[tuple[int, float, float]] = []
    odom: list[tuple[int, float, float, float, float, float, float, float, float]] = []
    with path.open("rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        for _, channel, message, msg in reader.iter_decoded_messages(
            topics=[cmd_topic, odom_topic]
        ):
            if channel.topic == odom_topic:
                st, p, q, tw = (
                    msg.header.stamp,
                    msg.pose.pose.position,
                    msg.pose.pose.orientation,
                    msg.twist.twist,
                )
                odom.append(
                    (
                        st.sec * 10**9 + st.nanosec,
                        tw.linear.x,
                        tw.angular.z,
                        p.x,
                        p.y,
                        q.x,
                        q.y,
                        q.z,
                        q.w,
                    )
                )
            else:
                cmd.append((message.log_time, msg.linear.x, msg.angular.z))
    np.array(cmd, dtype=np.float64)
    np.array(odom, dtype=np.float64)
    return len(cmd) + len(odom)


def _with_cpu(fn: Callable[[], object], cpu: list[float]) -> Callable[[], object]:
    """``fn`` that also appends its CPU seconds (user + system of this process) to ``cpu``."""

    def run() -> object:
        t0 = time.process_time()
        out = fn()
        cpu.append(time.process_time() - t0)
        return out

    return run


def _ratio_text(num: Stats, den: Stats) -> str:
    lo, med, hi = paired_ratios(num, den)
    return f"{lo:.1f}/{med:.1f}/{hi:.1f}x"


def _row(label: str, path: Path, repeats: int) -> tuple[float, float]:
    """In-process file -> arrays, alternated; returns the median (wall, CPU) speed-ups."""
    n_ours, n_base = _ours(path), _baseline(path)
    if n_ours != n_base:
        raise SystemExit(f"message counts differ: ours {n_ours}, mcap_ros2 {n_base}")
    cpu: dict[str, list[float]] = {"ours": [], "base": []}
    st = alternate(
        {
            "ours": _with_cpu(lambda: _ours(path), cpu["ours"]),
            "base": _with_cpu(lambda: _baseline(path), cpu["base"]),
        },
        repeats,
    )
    # the warm-up call of each side is recorded first: drop it
    c_ours, c_base = (Stats(times_s=tuple(cpu[k][1:])) for k in ("ours", "base"))
    print(
        f"{label:<30} {n_ours:>7} msgs  wall: ours {st['ours'].fmt()}, mcap_ros2 "
        f"{st['base'].fmt()}, speed-up {_ratio_text(st['base'], st['ours'])}"
    )
    print(
        f"{'':<30} {'':>7}       CPU:  ours {c_ours.fmt()}, mcap_ros2 {c_base.fmt()}, "
        f"speed-up {_ratio_text(c_base, c_ours)} (min/median/max of {repeats} alternated pairs)"
    )
    return paired_ratios(st["base"], st["ours"])[1], paired_ratios(c_base, c_ours)[1]


#: Whole-process programs, each what a user would write (argv[1]: the log).
_OURS_PROG = "import sys\nfrom sim2real.logs import read_trace\nread_trace(sys.argv[1])\n"
#: Python start-up plus numpy: what both sides pay before reading a byte.
_FLOOR_PROG = "import numpy\n"


def _peer_prog() -> str:
    """The baseline as a stand-alone script: :func:`_baseline`'s source and a call to it."""
    import inspect

    head = "from __future__ import annotations\nimport sys\nfrom pathlib import Path\n"
    head += "import numpy as np\n"
    return head + inspect.getsource(_baseline) + "\n_baseline(Path(sys.argv[1]))\n"


def _whole_process(label: str, path: Path, repeats: int) -> tuple[float, float]:
    """Whole-process file -> arrays (python start-up and imports included), cold and warm.

    Each side is the short script a user would write; the floor (``python -c "import
    numpy"``) is timed alongside, so the best possible speed-up, the baseline's time over
    the floor's, is printed too.
    """
    exe = sys.executable
    cmds = {
        "ours": [exe, "-c", _OURS_PROG, str(path)],
        "mcap_ros2": [exe, "-c", _peer_prog(), str(path)],
        "floor": [exe, "-c", _FLOOR_PROG],
    }
    res = command_times(cmds, repeats)
    (c_ours, w_ours), (c_base, w_base), (_c_floor, w_floor) = (
        res[k] for k in ("ours", "mcap_ros2", "floor")
    )
    cpu = {k: Stats(times_s=tuple(CPU_S[" ".join(cmds[k])][-repeats:])) for k in cmds}
    print(
        f"{label:<30} whole process, warm: ours {w_ours.fmt(1.0, 's')}, mcap_ros2 "
        f"{w_base.fmt(1.0, 's')}, speed-up {_ratio_text(w_base, w_ours)}; cold: ours "
        f"{c_ours:.2f} s, mcap_ros2 {c_base:.2f} s"
    )
    print(
        f"{'':<30} whole process CPU: ours {cpu['ours'].fmt(1.0, 's')}, mcap_ros2 "
        f"{cpu['mcap_ros2'].fmt(1.0, 's')}, speed-up {_ratio_text(cpu['mcap_ros2'], cpu['ours'])}"
    )
    print(
        f"{'':<30} floor (python + import numpy): wall {w_floor.fmt(1.0, 's')}, CPU "
        f"{cpu['floor'].fmt(1.0, 's')}; best possible speed-up (mcap_ros2 / floor): wall "
        f"{_ratio_text(w_base, w_floor)}, CPU {_ratio_text(cpu['mcap_ros2'], cpu['floor'])}"
    )
    return paired_ratios(w_base, w_ours)[1], paired_ratios(cpu["mcap_ros2"], cpu["ours"])[1]


_MEMORY_PROG = """
import json, sys, tracemalloc
sys.path.insert(0, {here!r})
import bench_decode as b
from pathlib import Path

def hwm():
    for line in open("/proc/self/status"):
        if line.startswith("VmHWM"):
            return int(line.split()[1]) * 1024
    return 0

import numpy, mcap_ros2.decoder, mcap.reader, sim2real.logs  # imports before the baseline
before = hwm()
tracemalloc.start()
out = b._memory_run({side!r}, Path({path!r}))
peak = tracemalloc.get_traced_memory()[1]
tracemalloc.stop()
print(json.dumps({{"tracemalloc": peak, "hwm_growth": hwm() - before, "output": out}}))
"""


def _memory_run(side: str, path: Path) -> int:
    """Decode ``path`` with one side; return the bytes of the arrays it produced."""
    if side == "ours":
        from sim2real.logs import read_trace

        tr = read_trace(path)
        arrays = [tr.cmd_t_ns, tr.cmd_v, tr.cmd_w, tr.meas_t_ns, tr.meas_v, tr.meas_w]
        arrays += [a for a in (tr.pose_x, tr.pose_y, tr.pose_yaw) if a is not None]
        return int(sum(a.nbytes for a in arrays))
    _baseline(path)
    return 0


def _largest_chunk(path: Path) -> int:
    from mcap.reader import make_reader

    with path.open("rb") as fh:
        summary = make_reader(fh).get_summary()
    assert summary is not None
    return max(c.compressed_size + c.uncompressed_size for c in summary.chunk_indexes)


def _memory(path: Path, repeats: int) -> tuple[float, float, bool]:
    """Peak memory of each side in its own process (median over repeats)."""
    here = str(Path(__file__).resolve().parent)
    got: dict[str, list[dict[str, int]]] = {"ours": [], "mcap_ros2": []}
    for i in range(repeats):
        for side in ("ours", "mcap_ros2") if i % 2 == 0 else ("mcap_ros2", "ours"):
            prog = _MEMORY_PROG.format(here=here, side=side, path=str(path))
            res = subprocess.run(
                [sys.executable, "-c", prog], capture_output=True, text=True, check=True
            )
            got[side].append(json.loads(res.stdout.strip().splitlines()[-1]))
    mib = 2.0**20

    def med(side: str, key: str) -> float:
        return statistics.median(r[key] for r in got[side]) / mib

    output = got["ours"][0]["output"] / mib
    chunk = _largest_chunk(path) / mib
    bound = 2 * (output + chunk)
    ours_peak = max(med("ours", "tracemalloc"), med("ours", "hwm_growth"))
    print(
        f"file {path.stat().st_size / mib:.1f} MiB, output arrays {output:.1f} MiB, largest "
        f"chunk {chunk:.1f} MiB (compressed + decompressed), bound 2 x (output + chunk) = "
        f"{bound:.1f} MiB"
    )
    for side in ("ours", "mcap_ros2"):
        print(
            f"  {side:<10} peak: tracemalloc {med(side, 'tracemalloc'):.1f} MiB, VmHWM growth "
            f"after imports {med(side, 'hwm_growth'):.1f} MiB (medians of {repeats} processes)"
        )
    base_peak = max(med("mcap_ros2", "tracemalloc"), med("mcap_ros2", "hwm_growth"))
    return ours_peak, base_peak, ours_peak <= bound


def main() -> None:
    quick = "--quick" in sys.argv
    reps = 3 if quick else 9
    print(
        "file -> arrays (read_trace vs make_reader + mcap_ros2 DecoderFactory), in process; "
        "the machine may be shared with other jobs: CPU times are printed beside wall times"
    )
    with tempfile.TemporaryDirectory() as tmp:
        path = _make_log(Path(tmp) / "bench.mcap")
        wall, cpu = _row("generated 50k odom + 20k cmd", path, reps)
        w_big, c_big = _whole_process("generated 50k odom + 20k cmd", path, 3)
        record(
            "decode",
            "decode speed-up vs mcap-ros2, generated 70k-message log, whole process",
            f"wall {w_big:.1f}x, CPU {c_big:.1f}x (medians of 3 alternated runs)",
            ">= 2x",
            w_big >= 2,
        )
        record(
            "decode",
            "decode speed-up vs mcap-ros2, generated 70k-message log, in process",
            f"wall {wall:.1f}x, CPU {cpu:.1f}x (medians of {reps} alternated pairs)",
            ">= 10x",
            wall >= 10,
        )
        for name in REAL_LOGS:
            real = REALDATA / name
            if not real.is_file():
                print(f"{name}: not found in {REALDATA}, skipped")
                continue
            w_in, c_in = _row(name, real, reps)
            w_proc, c_proc = _whole_process(name, real, reps)
            record(
                "decode",
                f"decode speed-up vs mcap-ros2, real log {name}",
                f"in process wall {w_in:.1f}x (CPU {c_in:.1f}x); whole process wall "
                f"{w_proc:.2f}x (CPU {c_proc:.2f}x) (warm medians)",
                ">= 20x in process, >= 2x whole process",
                w_in >= 20 and w_proc >= 2,
            )
        print("peak memory of a decode, each side in its own process:")
        n_odom = 100_000 if quick else 400_000
        big = _make_log(Path(tmp) / "big.mcap", n_odom=n_odom, n_cmd=n_odom // 2)
        ours_peak, base_peak, met = _memory(big, 1 if quick else 3)
        record(
            "decode",
            f"decode peak memory, generated {big.stat().st_size / 2**20:.0f} MiB log",
            f"ours {ours_peak:.0f} MiB, mcap-ros2 {base_peak:.0f} MiB",
            "<= 2 x (output arrays + largest chunk)",
            met,
        )


if __name__ == "__main__":
    main()
