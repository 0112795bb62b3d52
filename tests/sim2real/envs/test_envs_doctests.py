"""The examples in the docstrings of sim2real.envs run and print what they claim."""

from __future__ import annotations

import doctest
import importlib

import pytest

MODULES = [
    "sim2real.envs",
    "sim2real.envs.baselines",
    "sim2real.envs.car_baseline",
    "sim2real.envs.car_crossing",
    "sim2real.envs.crowd_nav",
    "sim2real.envs.depth",
    "sim2real.envs.geometry",
    "sim2real.envs.maps",
    "sim2real.envs.metrics",
    "sim2real.envs.orca",
    "sim2real.envs.pedestrians",
    "sim2real.envs.race",
    "sim2real.envs.race_baseline",
    "sim2real.envs.random_map",
    "sim2real.envs.tracks",
]


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name: str) -> None:
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0, f"{name} has no example"
    assert result.failed == 0
