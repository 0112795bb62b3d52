"""Real recordings damaged as users' recordings are: a clock set back, a file cut mid-write,
topics renamed, the command topic missing. Built from a real TurtleBot3 log, message by
message in its file order, with the ``mcap`` library's writer."""

from __future__ import annotations

import json
import struct
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer

from sim2real.cli import main
from sim2real.logs import read_trace, write_velocity_log

pytestmark = pytest.mark.realdata

ROBOT = "turtlebot3_waffle_pi"
NS = 10**9


def _odom_stamp_shift(data: bytes, dt_ns: int) -> bytes:
    """An Odometry message (ROS 2 CDR) with its header stamp moved by ``dt_ns``."""
    sec, nsec = struct.unpack_from("<iI", data, 4)  # after the 4-byte encapsulation header
    t = sec * NS + nsec + dt_ns
    out = bytearray(data)
    struct.pack_into("<iI", out, 4, t // NS, t % NS)
    return bytes(out)


def _rewrite(
    src: Path,
    dst: Path,
    *,
    topics: tuple[str, ...] = ("/cmd_vel", "/odom"),
    rename: dict[str, str] | None = None,
    shift: Callable[[int], int] | None = None,
    between_s: tuple[float, float] | None = None,
    compression: CompressionType = CompressionType.ZSTD,
) -> Path:
    """``src``'s messages of ``topics`` in file order, renamed, with times shifted by
    ``shift(log_time_ns)`` (log, publish and Odometry header times alike), and only those
    logged ``between_s`` seconds after the first message when given (the command in force
    at its start is repeated there, as a recorder started under a held command sees it)."""
    rename = rename or {}
    with src.open("rb") as f:
        messages = [
            (schema, channel, msg)
            for schema, channel, msg in make_reader(f).iter_messages(log_time_order=False)
            if schema is not None
        ]
    if between_s:
        start = messages[0][2].log_time
        lo, hi = (start + int(x * NS) for x in between_s)
        before = [m for m in messages if m[1].topic == "/cmd_vel" and m[2].log_time < lo]
        messages = [m for m in messages if lo <= m[2].log_time < hi]
        if before:
            schema, channel, msg = before[-1]
            held = replace(msg, log_time=lo, publish_time=lo)
            messages.insert(0, (schema, channel, held))
    with dst.open("wb") as g:
        writer = Writer(g, compression=compression)
        writer.start(profile="ros2", library="test")
        schemas: dict[int, int] = {}
        channels: dict[int, int] = {}
        for schema, channel, msg in messages:
            if channel.topic not in topics:
                continue
            if schema.id not in schemas:
                schemas[schema.id] = writer.register_schema(
                    schema.name, schema.encoding, schema.data
                )
            if channel.id not in channels:
                channels[channel.id] = writer.register_channel(
                    rename.get(channel.topic, channel.topic),
                    channel.message_encoding,
                    schemas[schema.id],
                    channel.metadata,
                )
            dt = shift(msg.log_time) if shift else 0
            data = _odom_stamp_shift(msg.data, dt) if channel.topic == "/odom" else msg.data
            writer.add_message(
                channels[channel.id], msg.log_time + dt, data, msg.publish_time + dt, msg.sequence
            )
        writer.finish()
    return dst


def _agree(log: Path, out: Path, capsys: pytest.CaptureFixture[str]) -> tuple[int, Any, str]:
    code = main(["agree", str(log), "--robot", ROBOT, "--engine", "reduced", "--json", str(out)])
    err = capsys.readouterr().err
    return code, json.loads(out.read_text()) if code == 0 else None, err


@pytest.fixture(scope="module")
def clean(drexel_log: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    out = tmp_path_factory.mktemp("clean") / "clean.json"
    args = ["agree", str(drexel_log), "--robot", ROBOT, "--engine", "reduced", "--json", str(out)]
    assert main(args) == 0
    return dict(json.loads(out.read_text()))


def test_a_clock_set_back_mid_recording_gives_the_clean_figures(
    drexel_log: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], clean: dict[str, Any]
) -> None:
    """The recorder's and the driver's clock step back 5 s half-way: the two stretches are
    used one after the other (not interleaved by a sort), with the figures of the clean log."""
    with drexel_log.open("rb") as f:
        times = [m.log_time for _, _, m in make_reader(f).iter_messages(log_time_order=False)]
    mid = times[len(times) // 2]
    log = _rewrite(drexel_log, tmp_path / "reset.mcap", shift=lambda t: -5 * NS if t > mid else 0)
    code, figures, err = _agree(log, tmp_path / "a.json", capsys)
    assert code == 0
    assert "the clock of topic '/odom' steps back 1 time(s) (by 4.97 s)" in err
    assert "the clock of topic '/cmd_vel' steps back 1 time(s)" in err
    assert figures["n_active"] == clean["n_active"]
    assert figures["agreement"] == pytest.approx(clean["agreement"], abs=0.005)


@pytest.mark.parametrize("compression", ["as recorded", "zstd", "lz4"])
def test_a_recording_cut_mid_write_keeps_what_it_wrote(
    drexel_log: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    clean: dict[str, Any],
    compression: str,
) -> None:
    """Cut at 60 % of its bytes, inside a chunk (the recorded file: 1 MB uncompressed chunks;
    rewritten: one compressed chunk, which the cut leaves without an end): the complete
    records of the cut chunk are kept (without them: 53 % of the recorded file's samples,
    none of a rewritten one)."""
    src = drexel_log
    if compression != "as recorded":
        kind = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4}[compression]
        src = _rewrite(drexel_log, tmp_path / "whole.mcap", compression=kind)
    data = src.read_bytes()
    log = tmp_path / "cut.mcap"
    log.write_bytes(data[: int(0.6 * len(data))])
    code, figures, err = _agree(log, tmp_path / "a.json", capsys)
    assert code == 0 and "Traceback" not in err
    assert "of records of the chunk cut there" in err
    assert 0.55 * clean["n_samples"] < figures["n_samples"] < clean["n_samples"]
    assert figures["agreement"] > 0.8


def test_renamed_topics_are_found_and_a_missing_command_topic_is_one_sentence(
    drexel_log: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], clean: dict[str, Any]
) -> None:
    names = {"/cmd_vel": "/robot1/cmd_vel", "/odom": "/robot1/odom"}
    renamed = _rewrite(drexel_log, tmp_path / "renamed.mcap", rename=names)
    code, figures, _ = _agree(renamed, tmp_path / "a.json", capsys)
    assert code == 0 and figures["agreement"] == pytest.approx(clean["agreement"], abs=1e-9)
    odom_only = _rewrite(drexel_log, tmp_path / "odom_only.mcap", topics=("/odom",))
    code, _, err = _agree(odom_only, tmp_path / "b.json", capsys)
    assert code == 2 and err.count("\n") == 1 and "Traceback" not in err
    assert "has no command topic" in err and "--cmd-topic" in err


#: Neato recordings of three units (the fleet's driving logs).
DRIVING = (
    "neato_ksoltan_drunk_wall_follow_demo_2018-09-18-20-35-31.mcap",
    "neato_ksoltan_square_dance_demo_2018-09-18-20-20-05.mcap",
    "neato_ksoltan_testdrive_2018-09-18-20-17-54.mcap",
    "neato_paulruvolo-pr2_drive_square_bag_2017-01-29-18-30-40.mcap",
    "neato_paulruvolo-pr2_person_follower_bag_2017-02-04-15-10-28.mcap",
    "neato_yycho0108_drive_square_demo.mcap",
    "neato_yycho0108_test_drive.mcap",
)


def test_a_real_fleet_goes_on_past_two_spins_in_place_and_a_corrupt_log(
    realdata_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """10 real Neato logs, 2 of them spins in place (the teleop log's 21 s spin at -1 rad/s,
    in two parts) and 1 cut before its first message: exit 0, 9 rows with figures, 1 row
    saying why; the spins' undefined figures are left out with a note, never null."""
    spec = tmp_path / "neato.yaml"
    argv = ["robots", "new", "neato", "--wheel-separation", "0.248", "--max-speed", "0.3"]
    assert main([*argv, "-o", str(spec)]) == 0
    teleop = realdata_dir / "neato_olin2018_teleop.mcap"
    spins = [
        _rewrite(teleop, tmp_path / f"spin{k}.mcap", between_s=span)
        for k, span in enumerate(((12.0, 21.0), (21.0, 30.5)))
    ]
    cut = tmp_path / "cut.mcap"
    cut.write_bytes((realdata_dir / DRIVING[0]).read_bytes()[:40])  # inside its header
    logs = [*(realdata_dir / n for n in DRIVING), *spins, cut]
    out = tmp_path / "fleet.json"
    capsys.readouterr()
    argv = ["agree", *map(str, logs), "--robot", str(spec), "--engine", "reduced"]
    assert main([*argv, "--json", str(out)]) == 0
    stdout = capsys.readouterr().out
    doc = json.loads(out.read_text())
    assert len(doc["logs"]) == 10 and doc["summary"]["n_logs"] == 9
    assert doc["summary"]["n_left_out"] == 1
    rows = {Path(f["log_file"]).name: f for f in doc["logs"]}
    assert "error" in rows["cut.mcap"] and "truncated" in rows["cut.mcap"]["error"]
    for k in range(2):
        spin = rows[f"spin{k}.mcap"]
        assert "lag_s_v" not in spin  # a cross-correlation of odometry noise, not a latency
        assert "fit_percent_v" not in spin  # a score of odometry noise against its mean
        assert "lag_s_w" not in spin  # a steady spin: its w is noise about -1 rad/s
        for key in ("lag_s_v", "fit_percent_v"):
            assert any(f"figure '{key}' is left out" in n for n in spin["notes"])
        assert 0.0 <= spin["agreement"] <= 1.0 and spin["agreement_v"] == 1.0
    assert None not in [v for f in doc["logs"] for k, v in f.items() if k != "params_file"]
    table = [ln for ln in stdout.splitlines() if ln.split(" ")[0].endswith(".mcap")]
    assert len(table) == 10 and sum("%" in row for row in table) == 9
    assert sum("left out:" in row for row in table) == 1


@pytest.mark.parametrize("rate_hz", [5.0, 100.0])
def test_odometry_resampled_to_5_or_100_hz_gives_the_same_agreement(
    drexel_log: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    clean: dict[str, Any],
    rate_hz: float,
) -> None:
    """The TurtleBot3's 23 Hz odometry (pose and twist) resampled to 5 Hz (nearest samples)
    or 100 Hz (linear interpolation): the agreement stays within 2 points of the log's own."""
    tr = read_trace(drexel_log)
    t = tr.meas_t_ns
    grid = np.arange(t[0], t[-1], int(NS / rate_hz))
    if rate_hz < 20:  # the nearest recorded sample at each tick
        idx = np.unique(np.clip(np.searchsorted(t, grid), 0, t.size - 1))
        meas = {k: getattr(tr, k)[idx] for k in ("meas_v", "meas_w", "pose_x", "pose_y")}
        meas["pose_yaw"], meas_t = tr.pose_yaw[idx], t[idx]
    else:
        f = {k: getattr(tr, k) for k in ("meas_v", "meas_w", "pose_x", "pose_y")}
        meas = {k: np.interp(grid, t, x) for k, x in f.items()}
        meas["pose_yaw"], meas_t = np.interp(grid, t, np.unwrap(tr.pose_yaw)), grid
    log = write_velocity_log(
        tmp_path / f"odom_{rate_hz:g}hz.mcap",
        cmd_t_ns=tr.cmd_t_ns, cmd_v=tr.cmd_v, cmd_w=tr.cmd_w, meas_t_ns=meas_t,
        meas_v=meas["meas_v"], meas_w=meas["meas_w"], pose_x=meas["pose_x"],
        pose_y=meas["pose_y"], pose_yaw=meas["pose_yaw"],
    )  # fmt: skip
    code, figures, _ = _agree(log, tmp_path / "a.json", capsys)
    assert code == 0
    assert figures["n_samples"] == pytest.approx(tr.meas_t_ns.size * rate_hz / 23.0, rel=0.15)
    assert figures["agreement"] == pytest.approx(clean["agreement"], abs=0.02)
