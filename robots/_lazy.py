"""A package's names loaded on first use (PEP 562): the ``__getattr__`` and ``__dir__`` of
``robots`` and ``sysid``, so that importing one of their modules stays light."""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping, Sequence
from typing import Any

__all__ = ["lazy_exports"]


def lazy_exports(
    package: str, homes: Mapping[str, str], namespace: dict[str, Any], exported: Sequence[str]
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """The module ``__getattr__`` and ``__dir__`` of ``package``.

    ``__getattr__`` imports a name of ``homes`` (``{name: module}``) from its module on first
    use and keeps it in ``namespace`` (the package's ``globals()``); ``__dir__`` lists the
    namespace and the ``exported`` names.
    """

    def __getattr__(name: str) -> Any:
        if name in homes:
            value = getattr(importlib.import_module(homes[name]), name)
            namespace[name] = value
            return value
        raise AttributeError(f"module '{package}' has no attribute {name!r}")

    def __dir__() -> list[str]:
        return sorted({*namespace, *exported})

    return __getattr__, __dir__
