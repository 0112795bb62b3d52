"""The examples in the robots modules' docstrings run and print what they claim."""

from __future__ import annotations

import doctest
import importlib

import pytest

MODULES = [
    "robots",
    "robots.spec",
    "robots.world",
    "robots.sensors",
    "robots.pybullet_robot",
    "robots._pybullet_robot",
    "robots._chain",
    "robots._kernel",
    "robots.check",
    "robots.files",
    "robots.units",
    "robots.arrays",
    "robots.template",
    "robots.specdoc",
]


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name: str) -> None:
    result = doctest.testmod(importlib.import_module(name), optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0 and result.failed == 0
