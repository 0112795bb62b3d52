"""Channel table and topic auto-detection (private)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sim2real.errors import MissingTopicError
from sim2real.logs._accum import channel_times
from sim2real.logs._mcap import ChannelRecord, Container, SchemaRecord
from sim2real.logs._schemas import JOINT_STATE, ODOMETRY, TWIST, TWIST_STAMPED, normalize_type

__all__ = ["CMD_TYPES", "MEAS_TYPES", "Chan", "channel_table", "choose_topic"]

#: Message types usable as commands / measurements, in order of preference.
CMD_TYPES = (TWIST_STAMPED, TWIST)
MEAS_TYPES = (ODOMETRY, JOINT_STATE)
_PREFERRED = {"command": ("/cmd_vel",), "measurement": ("/odom", "/joint_states")}
_FLAG = {
    "command": "--cmd-topic (cmd_topic= in Python)",
    "measurement": "--odom-topic (odom_topic= in Python)",
}


@dataclass(frozen=True)
class Chan:
    """One channel of a log with its message type and log times."""

    record: ChannelRecord
    schema: SchemaRecord | None
    type: str
    log_time_ns: np.ndarray

    @property
    def topic(self) -> str:
        """The channel's topic name."""
        return self.record.topic

    @property
    def count(self) -> int:
        """Number of messages on the channel."""
        return int(self.log_time_ns.size)

    @property
    def encoding(self) -> str:
        """Message encoding (``cdr``, ``json``, ...)."""
        return self.record.message_encoding

    def describe(self) -> str:
        """``/topic (type, N msgs)`` for messages."""
        return f"{self.topic} ({self.type or 'no schema'}, {self.count} msgs)"


def channel_table(container: Container, *, sort: bool = True) -> list[Chan]:
    """Every channel of the container with its type and sorted log times (``sort=False``:
    in no particular order, for a caller that only needs the counts)."""
    out = []
    for cid, rec in sorted(container.channels.items()):
        schema = container.schemas.get(rec.schema_id)
        parts = channel_times(container, cid)
        t = np.concatenate(parts) if parts else np.zeros(0, np.int64)
        if sort:
            # in place (one copy of the times, not two); stable = timsort, linear on the
            # already sorted runs of a log (faster than the default quicksort there), same result
            t.sort(kind="stable")
        type_name = normalize_type(schema.name) if schema is not None else ""
        out.append(Chan(record=rec, schema=schema, type=type_name, log_time_ns=t))
    return out


def _listing(chans: list[Chan]) -> str:
    return ", ".join(c.describe() for c in chans) or "none"


def choose_topic(chans: list[Chan], role: str, explicit: str | None, *, name: str) -> Chan:
    """Pick the command (``role="command"``) or measurement channel of a log.

    An explicit topic must exist and have a usable type. Otherwise the candidates are the
    channels of a usable type, non-empty ones first: a conventional name (``/cmd_vel``,
    ``/odom``, ``/joint_states``) wins, else the only candidate (for measurements the only
    Odometry channel, JointState only when there is no Odometry); several equal candidates
    are an error asking for the flag.
    """
    types = CMD_TYPES if role == "command" else MEAS_TYPES
    wanted = " or ".join(types)
    flag = _FLAG[role]
    if explicit is not None:
        found = [c for c in chans if c.topic == explicit]
        if not found:
            usable = [c.topic for c in chans if c.type in types]
            import difflib  # only for the error message

            close = difflib.get_close_matches(explicit, usable or [c.topic for c in chans], n=1)
            hint = f"did you mean '{close[0]}'? " if close else ""
            raise MissingTopicError(
                f"log file '{name}' has no topic '{explicit}' (asked for as the {role} topic); "
                f"{hint}topics present: {_listing(chans)}; pick one with {flag}"
            )
        if found[0].type not in types:
            raise MissingTopicError(
                f"topic '{explicit}' of log file '{name}' has type "
                f"'{found[0].type or 'unknown (no schema)'}', but the {role} topic needs "
                f"{wanted}; pick another with {flag}"
            )
        return found[0]
    cands = [c for c in chans if c.type in types]
    full = [c for c in cands if c.count > 0] or cands
    groups = [full] if role == "command" else [[c for c in full if c.type == t] for t in types]
    for group in groups:
        named = [c for c in group if c.topic in _PREFERRED[role]]
        if named or len(group) == 1:
            return (named or group)[0]
        if len(group) > 1:
            raise MissingTopicError(
                f"log file '{name}' has several possible {role} topics ({_listing(group)}); "
                f"choose one with {flag}"
            )
    raise MissingTopicError(
        f"log file '{name}' has no {role} topic of type {wanted}; topics present: "
        f"{_listing(chans)}; choose one with {flag}"
    )
