"""ROS 1 bags and rosbag2 folders through ``rosbags``, as a :class:`Container` (private).

The reader factory (:func:`open_log_source`) looks at a path and picks its reader, like
mcap's ``make_reader``: an MCAP file goes to our MCAP scan, a ROS 1 ``.bag`` (magic
``#ROSBAG V2.0``) and a rosbag2 folder (``metadata.yaml`` with sqlite3 or mcap storage) go to
the readers below, which use the maintained ``rosbags`` library (Ternaris) for the container:
bag header, chunks, compression, connection and index records, rosbag2 metadata and
storage plugins. Each reader yields only the channels whose type drives the trace
(commands: Twist, TwistStamped; measurements: Odometry, JointState) as message payloads with
integer-nanosecond log times; other channels contribute their log times only (counts and rates
for ``logs info``) and are never decoded, so a custom message (e.g. a bumper message with
camelCase fields) can never break a read. Channels whose type is not a standard ROS message
are listed in one note.

ROS 1 payloads keep their own serialisation (channel encoding ``ros1``); rosbag2 payloads are
ROS 2 CDR like MCAP's. Both then go through the same decoders as MCAP messages.
"""

from __future__ import annotations

import itertools
import os
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np

from sim2real.errors import LogFormatError, Sim2RealFileNotFoundError
from sim2real.logs._accum import DRIVE_TYPES, add_segment, times_only
from sim2real.logs._cdr import gather
from sim2real.logs._mcap import MAGIC, ChannelRecord, Container, SchemaRecord, Segment, stream_mcap
from sim2real.logs._schemas import (
    SCHEMA_TEXT,
    normalize_type,
)
from sim2real.logs._summary import stated_counts

__all__ = [
    "DRIVE_TYPES",
    "STANDARD_PACKAGES",
    "LogSource",
    "existing_log",
    "open_log_source",
    "source_kind",
]

_ROS1_MAGIC = b"#ROSBAG V"


@dataclass(frozen=True)
class LogSource:
    """A log picked by the factory: its kind, the files its digest covers and how to scan it."""

    kind: str  # "mcap", "ros1", "rosbag2" or "csv"
    path: Path
    #: The files whose concatenated bytes the log's SHA-256 covers (see open_log_source).
    digest_paths: tuple[Path, ...] = ()

    def scan(self, *, times_only: bool = False, keep_types: tuple[str, ...] = ()) -> Container:
        """The log's container: channels, schemas, warnings, and per channel the log times
        and the messages decoded chunk by chunk (:func:`sim2real.logs._accum.add_segment`);
        ``times_only`` keeps log times alone; ``keep_types`` keeps the payloads of more types."""
        container = Container(name=str(self.path), times_only=times_only, keep_types=keep_types)
        if self.kind == "mcap":
            with self.path.open("rb") as fh:
                size = os.fstat(fh.fileno()).st_size
                if not times_only:  # sizes the decoded arrays (memory follows the output)
                    container.expected = stated_counts(fh, size)
                    fh.seek(0)
                return stream_mcap(
                    fh, size, name=str(self.path), sink=add_segment, container=container
                )
        if self.kind == "ros1":
            return _scan_ros1(self.path, container)
        return _scan_rosbag2(self.path, container)


def source_kind(path: Path) -> str:
    """Which reader a path needs: ``mcap``, ``ros1``, ``rosbag2`` or ``csv``.

    A folder is a rosbag2 bag; a file is recognised by its magic bytes (MCAP, ROS 1 bag),
    else by its ``.csv`` suffix; anything else is handed to the MCAP reader, whose error says
    what the bytes are not.
    """
    if path.is_dir():
        return "rosbag2"
    with path.open("rb") as fh:
        head = fh.read(16)
    if head.startswith(MAGIC[:5]):
        return "mcap"
    if head.startswith(_ROS1_MAGIC):
        return "ros1"
    if path.suffix.lower() == ".csv":
        return "csv"
    if (
        path.name.lower().endswith((".db3", ".db3.zstd", ".mcap.zstd"))
        or path.name == "metadata.yaml"
    ):
        raise LogFormatError(
            f"log file '{path}' is not an MCAP file but one file of a rosbag2 folder; give "
            f"the folder '{path.parent}' instead"
        )
    return "mcap"


def existing_log(path: str | Path) -> Path:
    """The path of a log (file or folder), refused in one sentence when nothing is there."""
    p = Path(path)
    if not p.exists():
        raise Sim2RealFileNotFoundError(
            f"log file '{p}' does not exist; check the path (e.g. `ls {p.parent}`)"
        )
    return p


def open_log_source(path: Path) -> LogSource:
    """The factory: pick the reader for ``path`` (nothing is read yet but its first bytes).

    For a rosbag2 folder the hashed bytes are its ``metadata.yaml`` followed by its storage
    files in name order.
    """
    kind = source_kind(path)
    if kind != "rosbag2":
        return LogSource(kind=kind, path=path, digest_paths=(path,))
    meta = path / "metadata.yaml"
    if not meta.is_file():
        found = ", ".join(sorted(p.name for p in path.iterdir())[:5]) or "nothing"
        raise Sim2RealFileNotFoundError(
            f"log path '{path}' is a folder without a metadata.yaml, so it is not a rosbag2 "
            f"bag (found: {found}); give an .mcap, .bag or .csv file, or recreate the "
            f"metadata with `ros2 bag reindex {path}`"
        )
    # storage files, also zstd-compressed ones (`ros2 bag record --compression-mode file`)
    storage = (".db3", ".mcap", ".db3.zstd", ".mcap.zstd")
    files = (meta, *(p for p in sorted(path.iterdir()) if p.name.endswith(storage)))
    return LogSource(kind=kind, path=path, digest_paths=files)


# ------------------------------------------------------------------------------- shared


class _Table:
    """Channels (one per topic and type) and schemas being built for a container."""

    def __init__(self, container: Container) -> None:
        self.container = container
        self._ids: dict[tuple[str, str], int] = {}

    def channel(self, topic: str, type_name: str, encoding: str, msgdef: str) -> int:
        key = (topic, type_name)
        if key not in self._ids:
            cid = len(self._ids) + 1
            self._ids[key] = cid
            text = SCHEMA_TEXT.get(type_name, msgdef) if encoding == "cdr" else msgdef
            enc = "ros2msg" if encoding == "cdr" else "ros1msg"
            self.container.schemas[cid] = SchemaRecord(cid, type_name, enc, text.encode())
            self.container.channels[cid] = ChannelRecord(cid, cid, topic, encoding)
        return self._ids[key]


def _segment(
    buf: bytes, cid: np.ndarray, t: np.ndarray, off: np.ndarray, ln: np.ndarray
) -> Segment:
    return Segment(
        buf=buf,
        channel_id=cid.astype(np.uint16),
        log_time_ns=t.astype(np.int64),
        payload_off=off.astype(np.int64),
        payload_len=ln.astype(np.int64),
    )


def _note_unknown(container: Container, unknown: Iterable[tuple[str, str]]) -> None:
    items = sorted(set(unknown))
    if items:
        listing = ", ".join(f"{topic} ({type_name})" for topic, type_name in items)
        container.warnings.append(
            f"skipped {len(items)} channel(s) with message types that are not standard ROS "
            f"messages: {listing}; they are not needed for commands and odometry"
        )


#: The packages of the standard ROS 1 and ROS 2 message definitions: common_msgs and
#: common_interfaces, ros_comm and rcl_interfaces, geometry and geometry2 (tf, tf2_msgs), the
#: middleware's and rosbag2's own, nodelet bonds and dynamic_reconfigure. A channel of one of
#: these packages is a standard message even where the reader does not decode it.
STANDARD_PACKAGES = frozenset(
    {
        "action_msgs",
        "actionlib",
        "actionlib_msgs",
        "bond",
        "builtin_interfaces",
        "composition_interfaces",
        "diagnostic_msgs",
        "dynamic_reconfigure",
        "geometry_msgs",
        "libstatistics_collector",
        "lifecycle_msgs",
        "map_msgs",
        "nav_msgs",
        "pcl_msgs",
        "rcl_interfaces",
        "rmw_dds_common",
        "rosbag2_interfaces",
        "roscpp",
        "rosgraph_msgs",
        "sensor_msgs",
        "service_msgs",
        "shape_msgs",
        "statistics_msgs",
        "std_msgs",
        "std_srvs",
        "stereo_msgs",
        "tf",
        "tf2_msgs",
        "trajectory_msgs",
        "type_description_interfaces",
        "unique_identifier_msgs",
        "visualization_msgs",
    }
)


def _known_type(type_name: str) -> bool:
    """Whether ``type_name`` (``pkg/msg/Type``) is a message of a standard ROS package."""
    return type_name.split("/", 1)[0] in STANDARD_PACKAGES


# ------------------------------------------------------------------------------- ROS 1 bag


def _scan_ros1(path: Path, container: Container) -> Container:
    from rosbags.rosbag1 import Reader, ReaderError

    try:
        with Reader(path) as reader, path.open("rb") as fh:
            return _ros1_container(reader, fh, container)
    except (ReaderError, KeyError, ValueError, OSError) as exc:
        raise LogFormatError(
            f"log file '{path}' is not a readable ROS 1 bag ({exc}); check that the "
            "recording finished (`rosbag reindex` repairs an unindexed bag)"
        ) from None


def _ros1_container(reader: Any, fh: BinaryIO, container: Container) -> Container:
    """The bag's channels; the drive channels decoded one bag chunk at a time."""
    table = _Table(container)
    by_chunk: dict[int, list[tuple[int, np.ndarray, np.ndarray]]] = {}
    others: list[tuple[int, np.ndarray]] = []
    unknown = []
    for conn in reader.connections:
        type_name = normalize_type(conn.msgtype)
        cid = table.channel(conn.topic, type_name, "ros1", conn.msgdef.data)
        index = reader.indexes.get(conn.id, [])
        flat = itertools.chain.from_iterable(index)  # IndexData(time, chunk_pos, offset)
        rows = np.fromiter(flat, np.int64, count=3 * len(index)).reshape(-1, 3)
        if type_name not in (*DRIVE_TYPES, *table.container.keep_types):
            others.append((cid, rows[:, 0]))
            if not _known_type(type_name):
                unknown.append((conn.topic, type_name))
            continue
        for pos in np.unique(rows[:, 1]).tolist():
            sel = rows[rows[:, 1] == pos]
            by_chunk.setdefault(pos, []).append((cid, sel[:, 0], sel[:, 2]))
    for pos, parts in by_chunk.items():
        chunk = reader.chunks[pos]
        fh.seek(chunk.datapos)
        raw = chunk.decompressor(fh.read(chunk.datasize))
        seg = _ros1_segment(bytes(raw), parts)
        table.container.count += int(seg.channel_id.size)
        add_segment(table.container, seg)
    times_only(table.container, others)
    table.container.profile = "ros1"
    table.container.format = "ros1"
    table.container.library = "rosbags"
    _note_unknown(table.container, unknown)
    return table.container


def _ros1_segment(buf: bytes, parts: list[tuple[int, np.ndarray, np.ndarray]]) -> Segment:
    """Locate the payloads of message-data records in a decompressed chunk.

    A record is ``header_len u32, header, data_len u32, data`` (ROS bag format 2.0); the index
    gives each record's offset and time.
    """
    u8 = np.frombuffer(buf, dtype=np.uint8)
    cid = np.concatenate([np.full(o.size, c) for c, _, o in parts])
    t = np.concatenate([tt for _, tt, _ in parts])
    rec = np.concatenate([o for _, _, o in parts])
    if rec.size and (rec.min() < 0 or rec.max() + 4 > u8.size):
        raise ValueError("an index entry points outside its chunk")
    head_len = gather(u8, rec, "<u4").astype(np.int64)
    len_at = rec + 4 + head_len
    if np.any(len_at + 4 > u8.size):
        raise ValueError("a message record header runs past its chunk")
    data_len = gather(u8, len_at, "<u4").astype(np.int64)
    off = len_at + 4
    if np.any(off + data_len > u8.size):
        raise ValueError("a message record runs past its chunk")
    return _segment(buf, cid, t, off, data_len)


# ------------------------------------------------------------------------------- rosbag2


def _scan_rosbag2(path: Path, container: Container) -> Container:
    from rosbags.rosbag2 import Reader, ReaderError

    try:
        with Reader(path) as reader:
            return _rosbag2_container(reader, container)
    except (ReaderError, KeyError, ValueError, OSError) as exc:
        raise LogFormatError(
            f"log folder '{path}' is not a readable rosbag2 bag ({exc}); check its "
            "metadata.yaml and storage files (`ros2 bag info` shows the same problem)"
        ) from None


def _rosbag2_container(reader: Any, container: Container) -> Container:
    """The bag's channels; the drive channels' messages decoded in batches of
    :data:`_BATCH` messages, so memory follows the output rather than the bag."""
    table = _Table(container)
    wanted, cids = [], {}
    others: dict[int, list[int]] = {}
    unknown = []
    for conn in reader.connections:
        type_name = normalize_type(conn.msgtype)
        cid = table.channel(conn.topic, type_name, "cdr", conn.msgdef.data)
        cids[conn.id] = cid
        if type_name in (*DRIVE_TYPES, *table.container.keep_types):
            wanted.append(conn)
        else:
            others[cid] = []
            if not _known_type(type_name):
                unknown.append((conn.topic, type_name))
    batch: list[tuple[int, int, bytes]] = []
    for conn, t, raw in _messages(reader, wanted):
        batch.append((cids[conn.id], t, raw))
        if len(batch) >= _BATCH:
            _add_batch(table.container, batch)
            batch = []
    _add_batch(table.container, batch)
    other_conns = [c for c in reader.connections if cids[c.id] in others]
    for conn, t, _ in _messages(reader, other_conns):
        others[cids[conn.id]].append(t)
    times_only(table.container, [(c, np.array(t, np.int64)) for c, t in others.items()])
    table.container.profile = "ros2"
    table.container.format = "rosbag2"
    table.container.library = "rosbags"
    _note_unknown(table.container, unknown)
    return table.container


#: Messages of a rosbag2 bag decoded together.
_BATCH = 4096


def _add_batch(container: Container, batch: list[tuple[int, int, bytes]]) -> None:
    if not batch:
        return
    ln = np.fromiter((len(raw) for _, _, raw in batch), np.int64, len(batch))
    off = np.concatenate(([0], np.cumsum(ln)[:-1]))
    cid = np.fromiter((c for c, _, _ in batch), np.int64, len(batch))
    t = np.fromiter((t for _, t, _ in batch), np.int64, len(batch))
    seg = _segment(b"".join(raw for _, _, raw in batch), cid, t, off, ln)
    container.count += len(batch)
    add_segment(container, seg)


def _messages(reader: Any, conns: list[Any]) -> Iterator[tuple[Any, int, bytes]]:
    if not conns:
        return iter(())
    return iter(reader.messages(connections=conns))
