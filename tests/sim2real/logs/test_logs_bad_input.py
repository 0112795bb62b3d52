"""Bad and unusual logs: clear errors of our own types, or repairs recorded in meta.warnings."""

from __future__ import annotations

import json
import struct
from pathlib import Path

import numpy as np
import pytest
from logs_helpers import T0_NS, Arrays
from mcap.writer import CompressionType, Writer

from sim2real.errors import (
    LogFormatError,
    LogValueError,
    MissingTopicError,
    Sim2RealError,
    Sim2RealFileNotFoundError,
    Sim2RealValueError,
)
from sim2real.logs import (
    ODOMETRY,
    SCHEMA_TEXT,
    TWIST,
    _cdr,
    read_trace,
    write_joint_state_log,
    write_velocity_log,
)

MS = 1_000_000


def _custom_log(
    path: Path,
    channels: list[tuple[str, str, str, list[tuple[int, bytes]]]],
    **writer_kw,
) -> Path:
    """Write ``(topic, type, encoding, [(log_time, payload)])`` channels with mcap's Writer."""
    with path.open("wb") as fh:
        w = Writer(fh, **writer_kw)
        w.start(profile="ros2", library="test")
        msgs = []
        for topic, type_name, enc, items in channels:
            if type_name and enc == "cdr":
                sid = w.register_schema(type_name, "ros2msg", SCHEMA_TEXT[type_name].encode())
            elif type_name:
                sid = w.register_schema(type_name, "jsonschema", b"{}")
            else:
                sid = 0
            cid = w.register_channel(topic, enc, sid)
            msgs += [(t, cid, p) for t, p in items]
        for t, cid, p in sorted(msgs, key=lambda m: m[0]):
            w.add_message(cid, log_time=t, data=p, publish_time=t)
        w.finish()
    return path


def _twists(t: np.ndarray, v: np.ndarray, w: np.ndarray) -> list[tuple[int, bytes]]:
    return list(zip(t.tolist(), _cdr.encode_twist(v, w), strict=True))


def _odoms(t: np.ndarray, v: np.ndarray, w: np.ndarray, log_t=None) -> list[tuple[int, bytes]]:
    z = np.zeros(t.size)
    pays = _cdr.encode_odometry(t, v, w, x=z, y=z, yaw=z, frame_id="odom", child_frame_id="base")
    return list(zip((t if log_t is None else log_t).tolist(), pays, strict=True))


T = T0_NS + np.arange(20, dtype=np.int64) * 50 * MS
ONES, ZEROS = np.ones(20), np.zeros(20)


# ----------------------------------------------------------------------------- files
def test_missing_file(tmp_path: Path):
    with pytest.raises(Sim2RealFileNotFoundError, match=r"'.*nope\.mcap' does not exist"):
        read_trace(tmp_path / "nope.mcap")


def test_folder_instead_of_file(tmp_path: Path):
    with pytest.raises(Sim2RealFileNotFoundError, match=r"is a folder"):
        read_trace(tmp_path)


def test_empty_file(tmp_path: Path):
    (tmp_path / "e.mcap").write_bytes(b"")
    with pytest.raises(LogFormatError, match=r"is empty \(0 bytes\)"):
        read_trace(tmp_path / "e.mcap")


def test_not_an_mcap(tmp_path: Path):
    (tmp_path / "bag.db3").write_bytes(b"SQLite format 3\x00" + bytes(100))
    with pytest.raises(LogFormatError, match=r"is not an MCAP file") as info:
        read_trace(tmp_path / "bag.db3")
    assert isinstance(info.value, ValueError) and "\n" not in str(info.value)


def test_truncated_unchunked_log_keeps_complete_prefix(tmp_path: Path):
    path = _custom_log(
        tmp_path / "u.mcap",
        [
            ("/cmd_vel", TWIST, "cdr", _twists(T, ONES, ZEROS)),
            ("/odom", ODOMETRY, "cdr", _odoms(T + 1, ONES * 0.5, ZEROS)),
        ],
        use_chunking=False,
    )
    data = path.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) * 2 // 3])
    tr = read_trace(cut)
    assert 5 < tr.meta.meas_count < 20 and 5 < tr.meta.cmd_count < 20
    np.testing.assert_array_equal(tr.meas_t_ns, (T + 1)[: tr.meta.meas_count])
    assert np.all(tr.meas_v == 0.5)
    assert any("truncated" in w for w in tr.meta.warnings)


def test_truncated_chunk_without_complete_messages(tmp_path: Path, small_log: Path):
    data = small_log.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[:200])
    with pytest.raises(LogFormatError, match=r"truncated.*no complete message remains"):
        read_trace(cut)


def test_flipped_byte_in_chunk_fails_crc(tmp_path: Path, small_log: Path):
    data = bytearray(small_log.read_bytes())
    data[len(data) // 3] ^= 0x40
    bad = tmp_path / "flip.mcap"
    bad.write_bytes(bytes(data))
    with pytest.raises(LogFormatError, match=r"corrupt"):
        read_trace(bad)


@pytest.mark.parametrize(
    ("cut", "said"), [(0, r"is corrupt: the record at byte 8 "), (40, r"truncated")]
)
def test_record_length_past_end_of_file_is_an_error_not_a_crash(
    tmp_path: Path, small_log: Path, cut: int, said: str
):
    """An absurd record length is corruption in a finished file (its footer intact) and a
    recording cut short when the end of the file is missing too; never a crash."""
    data = bytearray(small_log.read_bytes())
    # The first record after the magic is the Header; make its length absurd.
    data[9:17] = struct.pack("<Q", 2**62)
    bad = tmp_path / "len.mcap"
    bad.write_bytes(bytes(data[: len(data) - cut]))
    with pytest.raises(LogFormatError, match=said):
        read_trace(bad)


# ----------------------------------------------------------------------------- topics
def test_no_command_topic_lists_topics_and_flag(tmp_path: Path):
    path = _custom_log(tmp_path / "n.mcap", [("/odom", ODOMETRY, "cdr", _odoms(T, ONES, ZEROS))])
    with pytest.raises(MissingTopicError) as info:
        read_trace(path)
    msg = str(info.value)
    assert "no command topic" in msg and "/odom (nav_msgs/msg/Odometry, 20 msgs)" in msg
    assert "--cmd-topic" in msg and isinstance(info.value, LookupError)


def test_no_measurement_topic(tmp_path: Path):
    path = _custom_log(tmp_path / "n.mcap", [("/cmd_vel", TWIST, "cdr", _twists(T, ONES, ZEROS))])
    with pytest.raises(MissingTopicError, match=r"no measurement topic.*--odom-topic"):
        read_trace(path)


def test_explicit_topic_must_exist_and_have_a_usable_type(small_log: Path):
    with pytest.raises(MissingTopicError, match=r"no topic '/cmd'.*/cmd_vel"):
        read_trace(small_log, cmd_topic="/cmd")
    with pytest.raises(MissingTopicError, match=r"has type 'nav_msgs/msg/Odometry'"):
        read_trace(small_log, cmd_topic="/odom")


def test_several_candidates_need_a_choice(tmp_path: Path):
    path = _custom_log(
        tmp_path / "two.mcap",
        [
            ("/nav/cmd", TWIST, "cdr", _twists(T, ONES, ZEROS)),
            ("/teleop/cmd", TWIST, "cdr", _twists(T + 5, ONES * 2, ZEROS)),
            ("/odom", ODOMETRY, "cdr", _odoms(T, ONES, ZEROS)),
        ],
    )
    with pytest.raises(
        MissingTopicError, match=r"several possible command topics.*/nav/cmd.*/teleop/cmd"
    ):
        read_trace(path)
    tr = read_trace(path, cmd_topic="/teleop/cmd")
    assert tr.meta.cmd_topic == "/teleop/cmd" and np.all(tr.cmd_v == 2.0)


def test_empty_topic(tmp_path: Path):
    path = _custom_log(
        tmp_path / "e.mcap",
        [("/cmd_vel", TWIST, "cdr", []), ("/odom", ODOMETRY, "cdr", _odoms(T, ONES, ZEROS))],
    )
    with pytest.raises(LogValueError, match=r"command topic '/cmd_vel'.*has no messages"):
        read_trace(path)


# ----------------------------------------------------------------------------- values
def test_nan_and_inf_samples_are_dropped_with_a_warning(tmp_path: Path, arrays: Arrays):
    kw = arrays.kwargs()
    kw["meas_v"] = kw["meas_v"].copy()
    kw["meas_v"][[3, 7]] = [np.nan, np.inf]
    kw["cmd_w"] = kw["cmd_w"].copy()
    kw["cmd_w"][0] = -np.inf
    tr = read_trace(write_velocity_log(tmp_path / "nan.mcap", **kw))
    assert tr.meta.meas_count == 98 and tr.meta.cmd_count == 39
    assert (
        np.all(np.isfinite(tr.meas_v)) and not np.isin(kw["meas_t_ns"][[3, 7]], tr.meas_t_ns).any()
    )
    assert "dropped 2 of 100 samples of topic '/odom' with NaN/inf values" in tr.meta.warnings
    assert "dropped 1 of 40 samples of topic '/cmd_vel' with NaN/inf values" in tr.meta.warnings


@pytest.mark.parametrize("encoding", ["cdr", "json"])
def test_all_nan_is_refused(tmp_path: Path, arrays: Arrays, encoding: str):
    kw = arrays.kwargs()
    kw["meas_w"] = np.full(100, np.nan)
    path = write_velocity_log(tmp_path / "nan.mcap", encoding=encoding, **kw)
    with pytest.raises(LogValueError, match=r"every one of the 100 samples of topic '/odom'"):
        read_trace(path)


def test_unsorted_and_duplicate_stamps_are_sorted_and_deduplicated(tmp_path: Path):
    stamps = T0_NS + np.array([0, 100, 50, 150, 150, 200], dtype=np.int64) * MS
    v = np.array([0.0, 1.0, 0.5, 1.5, 1.6, 2.0])
    path = write_velocity_log(
        tmp_path / "order.mcap",
        cmd_t_ns=T[:3],
        cmd_v=ONES[:3],
        cmd_w=ZEROS[:3],
        meas_t_ns=stamps,
        meas_v=v,
        meas_w=np.zeros(6),
        meas_log_t_ns=T0_NS + np.arange(6, dtype=np.int64) * 60 * MS,
    )
    tr = read_trace(path)
    np.testing.assert_array_equal(tr.meas_t_ns, T0_NS + np.array([0, 50, 100, 150, 200]) * MS)
    np.testing.assert_array_equal(tr.meas_v, [0.0, 0.5, 1.0, 1.6, 2.0])  # last of duplicates
    text = " ".join(tr.meta.warnings)
    assert "1 time steps that go backwards" in text and "1 duplicate timestamps" in text
    by_log = read_trace(path, time_source="log")
    assert by_log.meta.warnings == () and by_log.meta.meas_count == 6


def test_zero_header_stamps_fall_back_to_log_time(tmp_path: Path):
    path = _custom_log(
        tmp_path / "z.mcap",
        [
            ("/cmd_vel", TWIST, "cdr", _twists(T, ONES, ZEROS)),
            ("/odom", ODOMETRY, "cdr", _odoms(np.zeros(20, np.int64), ONES, ZEROS, log_t=T + 7)),
        ],
    )
    tr = read_trace(path)
    np.testing.assert_array_equal(tr.meas_t_ns, T + 7)
    assert tr.meta.meas_time_source == "log"
    assert any("zero or negative" in w for w in tr.meta.warnings)


def test_header_clock_far_from_log_clock_is_warned(tmp_path: Path):
    path = _custom_log(
        tmp_path / "clk.mcap",
        [
            ("/cmd_vel", TWIST, "cdr", _twists(T, ONES, ZEROS)),
            ("/odom", ODOMETRY, "cdr", _odoms(T - 100 * 10**9, ONES, ZEROS, log_t=T)),
        ],
    )
    tr = read_trace(path)
    assert any("+100.000 s (median) away from log times" in w for w in tr.meta.warnings)
    assert read_trace(path, time_source="log").meta.warnings == ()


def test_bad_time_source(small_log: Path):
    with pytest.raises(
        Sim2RealValueError, match=r"time_source must be 'header', 'log' or 'auto', got 'ros'"
    ):
        read_trace(small_log, time_source="ros")


def test_joint_state_needs_wheel_geometry(tmp_path: Path):
    path = write_joint_state_log(
        tmp_path / "js.mcap",
        cmd_t_ns=T,
        cmd_v=ONES,
        cmd_w=ZEROS,
        js_t_ns=T,
        left_radps=ONES,
        right_radps=ONES,
    )
    with pytest.raises(Sim2RealValueError, match=r"wheel_radius_m must be a positive number"):
        read_trace(path)
    with pytest.raises(Sim2RealValueError, match=r"wheel_separation_m"):
        read_trace(path, wheel_radius_m=0.05, wheel_separation_m=-1.0)


def test_joint_state_without_wheel_joints(tmp_path: Path):
    path = write_joint_state_log(
        tmp_path / "js.mcap",
        cmd_t_ns=T,
        cmd_v=ONES,
        cmd_w=ZEROS,
        js_t_ns=T,
        left_radps=ONES,
        right_radps=ONES,
        joint_names=("j1", "j2"),
    )
    with pytest.raises(LogValueError, match=r"joints \['j1', 'j2'\].*wheel_joints"):
        read_trace(path, wheel_radius_m=0.05, wheel_separation_m=0.3)


# ------------------------------------------------------------------------ other layouts
def test_lz4_chunks_schemaless_json_and_big_endian_cdr(tmp_path: Path):
    be = [
        b"\x00\x00\x00\x00" + struct.pack(">6d", v, 0, 0, 0, 0, -v) for v in np.linspace(0, 1, 20)
    ]
    odom_json = [
        json.dumps(
            {
                "header": {
                    "stamp": {"sec": int(t // 10**9), "nanosec": int(t % 10**9)},
                    "frame_id": "odom",
                },
                "child_frame_id": "base",
                "pose": {
                    "pose": {
                        "position": {"x": 1.0, "y": 2.0, "z": 0.0},
                        "orientation": {"x": 0, "y": 0, "z": 0, "w": 1},
                    }
                },
                "twist": {"twist": {"linear": {"x": 0.25}, "angular": {"z": -0.5}}},
            }
        ).encode()
        for t in T.tolist()
    ]
    path = _custom_log(
        tmp_path / "mix.mcap",
        [
            ("/cmd_vel", TWIST, "cdr", list(zip(T.tolist(), be, strict=True))),
            ("/odom_json", "", "json", list(zip((T + 3).tolist(), odom_json, strict=True))),
        ],
        compression=CompressionType.LZ4,
    )
    tr = read_trace(path)
    np.testing.assert_array_equal(tr.cmd_v, np.linspace(0, 1, 20))
    np.testing.assert_array_equal(tr.cmd_w, -np.linspace(0, 1, 20))
    assert (tr.meta.meas_topic, tr.meta.meas_type, tr.meta.encoding) == (
        "/odom_json",
        ODOMETRY,
        "json",
    )
    np.testing.assert_array_equal(tr.meas_t_ns, T)  # header stamps, not log time T + 3
    assert np.all(tr.meas_v == 0.25) and np.all(tr.pose_y == 2.0) and np.all(tr.pose_yaw == 0.0)


def test_garbage_json_message_is_a_format_error(tmp_path: Path):
    path = _custom_log(
        tmp_path / "gj.mcap",
        [
            ("/cmd_vel", TWIST, "json", [(int(T[0]), b"{not json")]),
            ("/odom", ODOMETRY, "cdr", _odoms(T, ONES, ZEROS)),
        ],
    )
    with pytest.raises(LogFormatError, match=r"topic '/cmd_vel'.*cannot be decoded"):
        read_trace(path)


def test_cut_cdr_payload_is_a_format_error(tmp_path: Path):
    odoms = _odoms(T, ONES, ZEROS)
    odoms[4] = (odoms[4][0], odoms[4][1][:100])
    path = _custom_log(
        tmp_path / "cut.mcap",
        [("/cmd_vel", TWIST, "cdr", _twists(T, ONES, ZEROS)), ("/odom", ODOMETRY, "cdr", odoms)],
    )
    with pytest.raises(LogFormatError, match=r"message 4 of topic '/odom'.*Odometry layout"):
        read_trace(path)


def test_every_error_is_a_sim2real_error():
    for cls in (LogFormatError, LogValueError, MissingTopicError, Sim2RealFileNotFoundError):
        assert issubclass(cls, Sim2RealError)


def _record_starts(data: bytes) -> list[tuple[int, int]]:
    """(offset, opcode) of the top-level records of an MCAP file."""
    pos, out = 8, []
    while pos + 9 <= len(data):
        op, length = struct.unpack_from("<BQ", data, pos)
        out.append((pos, op))
        if op == 0x02:
            break
        pos += 9 + length
    return out


def test_skipped_chunk_without_crcs_is_caught_by_the_statistics(tmp_path: Path):
    """A chunk whose opcode was damaged vanishes silently unless the summary count is checked."""
    path = _custom_log(
        tmp_path / "nocrc.mcap",
        [
            ("/cmd_vel", TWIST, "cdr", _twists(T, ONES, ZEROS)),
            ("/odom", ODOMETRY, "cdr", _odoms(T + 1, ONES, ZEROS)),
        ],
        compression=CompressionType.NONE,
        enable_crcs=False,
        chunk_size=500,
    )
    data = bytearray(path.read_bytes())
    chunks = [pos for pos, op in _record_starts(bytes(data)) if op == 0x06]
    assert len(chunks) > 3
    assert read_trace(path).meta.meas_count == 20
    data[chunks[2]] = 0x0C + 0x10  # an opcode no reader knows: the record is skipped
    bad = tmp_path / "skipped.mcap"
    bad.write_bytes(bytes(data))
    with pytest.raises(
        LogFormatError, match=r"summary counts 40 messages but its data section holds \d+"
    ):
        read_trace(bad)


def test_detection_prefers_conventional_names_and_odometry(tmp_path: Path):
    from sim2real.logs import JOINT_STATE, TWIST_STAMPED

    stamped = list(
        zip(T.tolist(), _cdr.encode_twist_stamped(T, ONES, ZEROS, frame_id="b"), strict=True)
    )
    js = [
        (
            t,
            _cdr.encode_joint_state(
                t,
                frame_id="",
                names=["left_wheel", "right_wheel"],
                position=[0, 0],
                velocity=[1.0, 1.0],
                effort=[],
            ),
        )
        for t in T.tolist()
    ]
    path = _custom_log(
        tmp_path / "pick.mcap",
        [
            ("/cmd_vel", TWIST, "cdr", _twists(T, ONES, ZEROS)),
            ("/nav/cmd_stamped", TWIST_STAMPED, "cdr", stamped),
            ("/joint_states", JOINT_STATE, "cdr", js),
            ("/wheel/odometry", ODOMETRY, "cdr", _odoms(T, ONES, ZEROS)),
        ],
    )
    tr = read_trace(path)
    assert (tr.meta.cmd_topic, tr.meta.meas_topic) == ("/cmd_vel", "/wheel/odometry")
    tr = read_trace(
        path,
        cmd_topic="/nav/cmd_stamped",
        odom_topic="/joint_states",
        wheel_radius_m=0.1,
        wheel_separation_m=0.2,
    )
    assert tr.meta.cmd_time_source == "header" and np.allclose(tr.meas_v, 0.1)


def test_twist_and_twist_stamped_without_cmd_vel_is_ambiguous(tmp_path: Path):
    from sim2real.logs import TWIST_STAMPED

    stamped = list(
        zip(T.tolist(), _cdr.encode_twist_stamped(T, ONES, ZEROS, frame_id="b"), strict=True)
    )
    path = _custom_log(
        tmp_path / "amb.mcap",
        [
            ("/a", TWIST, "cdr", _twists(T, ONES, ZEROS)),
            ("/b", TWIST_STAMPED, "cdr", stamped),
            ("/odom", ODOMETRY, "cdr", _odoms(T, ONES, ZEROS)),
        ],
    )
    with pytest.raises(MissingTopicError, match=r"several possible command topics \(/a .*, /b "):
        read_trace(path)


def test_a_log_whose_command_topic_is_empty_is_written_and_then_refused(tmp_path: Path) -> None:
    """Writing an empty stream is allowed (odometry-only logs); reading it names the topic."""
    t = T0_NS + np.arange(5, dtype=np.int64) * 100 * MS
    empty_t = np.array([], dtype=np.int64)
    path = write_velocity_log(
        tmp_path / "odom_only.mcap",
        cmd_t_ns=empty_t,
        cmd_v=np.array([]),
        cmd_w=np.array([]),
        meas_t_ns=t,
        meas_v=np.ones(5),
        meas_w=np.zeros(5),
    )
    with pytest.raises(LogValueError, match=r"'/cmd_vel'.*has no messages"):
        read_trace(path)
