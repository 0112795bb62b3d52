"""The docstring examples of the randomizers package run and give the values they show."""

from __future__ import annotations

import doctest
import importlib

import pytest

#: The modules that carry examples (each must run at least one, so none passes vacuously).
MODULES = [
    "randomizers",
    "randomizers._base",
    "randomizers._config",
    "randomizers._delay",
    "randomizers._dynamics",
    "randomizers._gauss",
]


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name: str) -> None:
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS, verbose=False)
    assert result.attempted > 0, f"{name} has no example"
    assert result.failed == 0, f"{result.failed} failing example(s) in {name}"
