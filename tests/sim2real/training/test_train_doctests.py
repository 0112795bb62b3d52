"""The examples in the docstrings of sim2real.training and sim2real.cluster run."""

from __future__ import annotations

import doctest
import importlib

import pytest


@pytest.mark.parametrize(
    "name",
    [
        "sim2real.training.config",
        "sim2real.training.environment",
        "sim2real.training.train",
        "sim2real.training.evaluation",
        "sim2real.cluster",
    ],
)
def test_docstring_examples(name: str) -> None:
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0, f"{name} has no example"
    assert result.failed == 0
