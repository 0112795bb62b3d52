"""MCAP-level integrity (issue 13 item 3): a file without CRCs is noted once by ``logs info``;
a message naming a channel id that no Channel record defines is an error naming its offset."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from logs_helpers import make_arrays
from mcap.writer import CompressionType, Writer

from sim2real.errors import LogFormatError
from sim2real.logs import ODOMETRY, SCHEMA_TEXT, TWIST, _cdr, inspect_log, read_trace
from sim2real.logs._info import NO_CHECKSUMS

_ARR = make_arrays(n_cmd=20, n_meas=60, seed=3)


def _write(
    path: Path,
    *,
    crcs: bool,
    compression: CompressionType = CompressionType.NONE,
    use_chunking: bool = True,
    stray_channel: int | None = None,
) -> Path:
    """Commands and odometry; with ``stray_channel`` one extra message names that channel id."""
    with path.open("wb") as fh:
        w = Writer(
            fh,
            compression=compression,
            enable_crcs=crcs,
            enable_data_crcs=crcs,
            chunk_size=2000,
            use_chunking=use_chunking,
        )
        w.start(profile="ros2", library="integrity-test")
        twist = w.register_schema(TWIST, "ros2msg", SCHEMA_TEXT[TWIST].encode())
        odom = w.register_schema(ODOMETRY, "ros2msg", SCHEMA_TEXT[ODOMETRY].encode())
        cmd_id = w.register_channel("/cmd_vel", "cdr", twist)
        odom_id = w.register_channel("/odom", "cdr", odom)
        rows = [
            (int(t), cmd_id, p)
            for t, p in zip(_ARR.cmd_t_ns, _cdr.encode_twist(_ARR.cmd_v, _ARR.cmd_w), strict=True)
        ]
        meas = _cdr.encode_odometry(
            _ARR.meas_t_ns,
            _ARR.meas_v,
            _ARR.meas_w,
            x=np.zeros_like(_ARR.meas_v),
            y=np.zeros_like(_ARR.meas_v),
            yaw=np.zeros_like(_ARR.meas_v),
            frame_id="odom",
            child_frame_id="base_link",
        )
        rows += [(int(t), odom_id, p) for t, p in zip(_ARR.meas_t_ns, meas, strict=True)]
        rows.sort(key=lambda r: r[0])
        if stray_channel is not None:
            t, _, payload = rows[len(rows) // 2]
            rows.insert(len(rows) // 2, (t, stray_channel, payload))
        for seq, (t, cid, payload) in enumerate(rows):
            w.add_message(cid, log_time=t, data=payload, publish_time=t, sequence=seq)
        w.finish()
    return path


def test_file_without_crcs_is_noted_once(tmp_path: Path) -> None:
    info = inspect_log(_write(tmp_path / "nocrc.mcap", crcs=False))
    assert info.warnings.count(NO_CHECKSUMS) == 1
    assert len(info.warnings) == 1


@pytest.mark.parametrize("compression", [CompressionType.NONE, CompressionType.ZSTD])
def test_file_with_crcs_has_no_note(tmp_path: Path, compression: CompressionType) -> None:
    info = inspect_log(_write(tmp_path / "crc.mcap", crcs=True, compression=compression))
    assert NO_CHECKSUMS not in info.warnings
    assert info.message_count == 80


def test_no_checksum_note_reaches_the_cli(tmp_path: Path, capsys: pytest.CaptureFixture[str]):
    from sim2real.cli import main

    assert main(["logs", "info", str(_write(tmp_path / "n.mcap", crcs=False))]) == 0
    out = capsys.readouterr()
    assert (out.out + out.err).count(NO_CHECKSUMS) == 1


@pytest.mark.parametrize(
    ("compression", "use_chunking"),
    [(CompressionType.NONE, True), (CompressionType.ZSTD, True), (CompressionType.NONE, False)],
    ids=["chunked", "zstd", "unchunked"],
)
def test_unknown_channel_id_is_an_error_naming_the_offset(
    tmp_path: Path, compression: CompressionType, use_chunking: bool
) -> None:
    path = _write(
        tmp_path / "stray.mcap",
        crcs=False,
        compression=compression,
        use_chunking=use_chunking,
        stray_channel=9,
    )
    for read in (inspect_log, read_trace):
        with pytest.raises(LogFormatError, match="names channel id 9") as exc:
            read(path)
        msg = str(exc.value)
        assert "stray.mcap" in msg and "re-export or re-record" in msg
        offset = int(re.search(r"message record at byte (\d+)", msg).group(1))  # type: ignore[union-attr]
        if compression == CompressionType.NONE:
            data = path.read_bytes()  # the offset points at that Message record in the file
            assert data[offset] == 0x05
            assert int.from_bytes(data[offset + 9 : offset + 11], "little") == 9
        else:
            assert "decompressed chunk at byte" in msg


def test_the_same_file_without_the_stray_message_reads(tmp_path: Path) -> None:
    tr = read_trace(_write(tmp_path / "ok.mcap", crcs=False))
    assert tr.meta.meas_count == 60 and tr.meta.cmd_count == 20
