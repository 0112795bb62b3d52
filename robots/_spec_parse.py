"""Strict readers for the sections of a robot spec YAML file (private helpers of robots.spec).

Every reader refuses unknown keys, reports missing keys and non-physical values with a
:class:`~robots.errors.SpecError` that names the file and the dotted key.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from robots.errors import SpecError

__all__ = ["Section"]


class Section:
    """A mapping from a spec file, read key by key with checks.

    Parameters
    ----------
    data : Mapping
        The YAML mapping.
    where : str
        Dotted path of this mapping in the file (``""`` for the top level), for messages.
    source : str
        The file (or name) the mapping came from, for messages.
    """

    def __init__(self, data: Any, where: str, source: str) -> None:
        self.source = source
        self.where = where
        if not isinstance(data, Mapping):
            raise SpecError(
                f"robot spec '{source}': '{where or 'the file'}' must be a mapping of "
                f"key: value, got {type(data).__name__}; fix the spec file"
            )
        self.data: Mapping[str, Any] = data
        self.used: set[str] = set()

    def key(self, name: str) -> str:
        """Dotted name of ``name`` inside this section."""
        return f"{self.where}.{name}" if self.where else name

    def fail(self, name: str, rule: str, value: Any) -> SpecError:
        """The error for key ``name`` breaking ``rule`` with ``value``."""
        return SpecError(
            f"robot spec '{self.source}': key '{self.key(name)}' {rule}, got {value!r}; "
            "fix the spec file"
        )

    def raw(self, name: str, *, optional: bool = False) -> Any:
        """The value of ``name`` (``None`` when optional and absent)."""
        self.used.add(name)
        if name not in self.data:
            if optional:
                return None
            raise SpecError(
                f"robot spec '{self.source}': required key '{self.key(name)}' is missing; "
                "add it (see robots/specs/turtlebot3_burger.yaml for the layout)"
            )
        return self.data[name]

    def number(
        self, name: str, *, positive: bool = False, nonneg: bool = False, allow_inf: bool = False
    ) -> float:
        """A real number, optionally > 0 or >= 0; inf only when ``allow_inf``."""
        value = self.raw(name)
        if isinstance(value, bool) or not isinstance(value, int | float) or math.isnan(value):
            raise self.fail(name, "must be a number", value)
        if math.isinf(value) and not (allow_inf and value > 0):
            raise self.fail(name, "must be finite", value)
        if positive and value <= 0:
            raise self.fail(name, "must be > 0 (non-physical otherwise)", value)
        if nonneg and value < 0:
            raise self.fail(name, "must be >= 0 (non-physical otherwise)", value)
        return float(value)

    def integer(self, name: str, *, minimum: int = 1) -> int:
        """An integer >= ``minimum``."""
        value = self.raw(name)
        if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
            raise self.fail(name, f"must be an integer >= {minimum}", value)
        return int(value)

    def text(self, name: str, *, choices: Sequence[str] | None = None) -> str:
        """A non-empty string, optionally one of ``choices``."""
        value = self.raw(name)
        if not isinstance(value, str) or not value.strip():
            raise self.fail(name, "must be a non-empty string", value)
        if choices is not None and value not in choices:
            raise self.fail(name, f"must be one of {list(choices)}", value)
        return value

    def vector(self, name: str, n: int = 3, *, positive: bool = False) -> tuple[float, ...]:
        """A list of ``n`` finite numbers (all > 0 when ``positive``)."""
        value = self.raw(name)
        ok = isinstance(value, list | tuple) and len(value) == n
        ok = ok and all(
            isinstance(x, int | float) and not isinstance(x, bool) and math.isfinite(x)
            for x in value
        )
        if not ok:
            raise self.fail(name, f"must be a list of {n} finite numbers", value)
        if positive and any(x <= 0 for x in value):
            raise self.fail(name, "must hold numbers > 0 (non-physical otherwise)", value)
        return tuple(float(x) for x in value)

    def section(self, name: str) -> Section:
        """The nested mapping ``name`` as a Section."""
        return Section(self.raw(name), self.key(name), self.source)

    def sections(self, name: str) -> list[Section]:
        """The list of mappings ``name`` (may be empty)."""
        value = self.raw(name)
        if not isinstance(value, list):
            raise self.fail(name, "must be a list (use [] for none)", value)
        return [
            Section(item, f"{self.key(name)}[{i}]", self.source) for i, item in enumerate(value)
        ]

    def finish(self) -> None:
        """Refuse keys that no reader asked for."""
        unknown = sorted(set(self.data) - self.used)
        if unknown:
            raise SpecError(
                f"robot spec '{self.source}': unknown key '{self.key(str(unknown[0]))}' "
                f"(unknown: {[self.key(str(u)) for u in unknown]}); known keys here are "
                f"{sorted(self.used)}; remove or rename it"
            )
