"""Decode speed: sim2real.logs bulk numpy path vs message-by-message mcap-ros2-support.

Run: ``.venv/bin/python benchmarks/bench_decode.py [--quick]``. Ours and the baseline are
alternated in one process with the same repeat count (min/median/max printed), on a generated
ROS 2 log (50 Hz Odometry x 1000 s = 50k messages, 20 Hz
Twist = 20k) and on the real logs in ../shared/realdata when present; on the real logs also whole processes (start-up and imports included, cold and
warm), as a user runs a decode.

Both sides go from the file on disk to numpy arrays of the same fields (stamps or log times,
v, w and, for Odometry, x, y and the quaternion):

- ours: :func:`sim2real.logs.read_trace` (read and SHA-256 the file, scan the chunks through
  their MessageIndex records, bulk CDR decode, sort/clean, build Trace);
- baseline: ``mcap.reader.make_reader(..., decoder_factories=[mcap_ros2 DecoderFactory()])``
  and ``iter_decoded_messages``, reading the fields of each decoded object.

A second table times the payload decoders alone on pre-extracted payload bytes.
"""

from __future__ import annotations

import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from _timing import alternate, command_times, paired_ratios, record

REALDATA = Path(__file__).resolve().parents[1].parent / "shared" / "realdata"
T0_NS = 1_700_000_000 * 10**9


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


def _best(fn: Callable[[], int], repeat: int) -> tuple[float, int]:
    times, n = [], 0
    for _ in range(repeat):
        t = time.perf_counter()
        n = fn()
        times.append(time.perf_counter() - t)
    return min(times), n


def _row(label: str, path: Path, repeats: int) -> float:
    """In-process file -> arrays, ours and mcap_ros2 alternated, same repeat count."""
    n_ours, n_base = _ours(path), _baseline(path)
    if n_ours != n_base:
        raise SystemExit(f"message counts differ: ours {n_ours}, mcap_ros2 {n_base}")
    st = alternate({"ours": lambda: _ours(path), "base": lambda: _baseline(path)}, repeats)
    lo, med, hi = paired_ratios(st["base"], st["ours"])
    print(
        f"{label:<28} {n_ours:>7} msgs  ours {st['ours'].fmt()}  mcap_ros2 {st['base'].fmt()}  "
        f"speed-up {lo:.1f}/{med:.1f}/{hi:.1f}x (min/median/max of {repeats} alternated pairs)"
    )
    return med


def _whole_process(label: str, path: Path, repeats: int) -> float:
    """Whole-process file -> arrays (python start-up and imports included), cold and warm."""
    here = Path(__file__).resolve().parent
    prog = f"import sys; sys.path.insert(0, {str(here)!r}); import bench_decode as b; b.{{}}"
    cmds = {
        "ours": [sys.executable, "-c", prog.format(f"_ours(b.Path({str(path)!r}))")],
        "mcap_ros2": [sys.executable, "-c", prog.format(f"_baseline(b.Path({str(path)!r}))")],
    }
    res = command_times(cmds, repeats)
    (c_ours, w_ours), (c_base, w_base) = res["ours"], res["mcap_ros2"]
    lo, med, hi = paired_ratios(w_base, w_ours)
    print(
        f"{label:<28} whole process: ours cold {c_ours:.2f} s, warm {w_ours.fmt(1.0, 's')}; "
        f"mcap_ros2 cold {c_base:.2f} s, warm {w_base.fmt(1.0, 's')}; "
        f"speed-up {lo:.2f}/{med:.2f}/{hi:.2f}x"
    )
    return med


def _decoder_only(path: Path) -> float:
    """Payload decoding alone: bulk numpy decoder vs mcap_ros2's decoder per payload."""
    from mcap.records import Schema
    from mcap_ros2.decoder import DecoderFactory

    from sim2real.logs import _cdr
    from sim2real.logs._reader import load_log

    log = load_log(path)
    chan = next(c for c in log.chans if c.topic == "/odom")
    seg_parts = [(s, s.channel_id == chan.record.id) for s in log.container.segments]
    payloads = [
        s.buf[o : o + n]
        for s, m in seg_parts
        for o, n in zip(s.payload_off[m].tolist(), s.payload_len[m].tolist(), strict=True)
    ]
    buf = b"".join(payloads)
    lens = np.array([len(p) for p in payloads], dtype=np.int64)
    offs = np.concatenate([[0], np.cumsum(lens)[:-1]]).astype(np.int64)
    u8 = np.frombuffer(buf, dtype=np.uint8)
    assert chan.schema is not None
    schema = Schema(id=1, name=chan.schema.name, encoding="ros2msg", data=chan.schema.data)
    decode = DecoderFactory().decoder_for("cdr", schema)
    assert decode is not None

    t_bulk, _ = _best(lambda: _cdr.decode_odometry(u8, offs, lens)["v"].size, 5)

    def generic() -> int:
        return len([decode(p).twist.twist.linear.x for p in payloads])

    t_gen, _ = _best(generic, 2)
    n = len(payloads)
    ratio = t_gen / t_bulk
    print(
        f"{'Odometry payloads only':<28} {n:>7} msgs  ours {n / t_bulk:>12,.0f} msg/s  "
        f"mcap_ros2 {n / t_gen:>10,.0f} msg/s  ratio {ratio:6.1f}x"
    )
    return ratio


def main() -> None:
    quick = "--quick" in sys.argv
    reps = 3 if quick else 7
    print("file -> arrays (read_trace vs make_reader + mcap_ros2 DecoderFactory), in process:")
    with tempfile.TemporaryDirectory() as tmp:
        path = _make_log(Path(tmp) / "bench.mcap")
        ratio = _row("generated 50k odom + 20k cmd", path, reps)
        record(
            "decode",
            "decode speed-up vs mcap-ros2, generated 70k-message log, in process",
            f"{ratio:.1f}x (median of {reps} alternated pairs)",
            ">= 10x",
            ratio >= 10,
        )
        for name in ("tb3wp_drexel_goal.mcap", "neato_olin2018_teleop.mcap"):
            real = REALDATA / name
            if real.is_file():
                r_in = _row(name, real, reps)
                r_proc = _whole_process(name, real, reps)
                record(
                    "decode",
                    f"decode speed-up vs mcap-ros2, real log {name}",
                    f"in process {r_in:.1f}x; whole process {r_proc:.2f}x (warm medians)",
                    ">= 20x in process, >= 2x whole process",
                    r_in >= 20 and r_proc >= 2,
                )
        print("decoders alone, same payload bytes:")
        _decoder_only(path)
    verdict = "meets" if ratio >= 10 else "MISSES"
    print(f"generated-log ratio {ratio:.1f}x {verdict} the >= 10x target")


if __name__ == "__main__":
    main()
