"""The docstring examples of the randomizers package run and give the values they show."""

from __future__ import annotations

import doctest
import importlib
import pkgutil

import pytest

import randomizers

MODULES = ["randomizers"] + [
    f"randomizers.{m.name}" for m in pkgutil.iter_modules(randomizers.__path__)
]


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name: str) -> None:
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS, verbose=False)
    assert result.failed == 0, f"{result.failed} failing example(s) in {name}"
