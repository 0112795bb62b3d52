"""The lower floors (robots, sysid, randomizers) keep the house rules that scripts/house_metrics.py
measures: who imports whom, no cycles, imports at the top, short functions, no dates."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
import house_metrics

FLOORS = ("robots", "sysid", "randomizers")
#: What each floor may import of the project (its own package aside).
MAY_IMPORT = {"robots": set(), "sysid": {"robots"}, "randomizers": {"robots"}}
#: Imports written inside functions in the floors, each keeping a light command light.
DEFERRED = {
    ("robots._pybullet", "pybullet"),  # the banner-free import itself
    ("robots._jit", "numba"),  # kernels compile on first use
    ("robots.check", "robots._pybullet_robot"),  # `robots check --no-drive` needs no pybullet
    ("robots.mjcf", "robots._pybullet_robot"),  # its tyre rule; `agree` imports robots.mjcf
    ("sysid._fleet", "scipy.special"),  # sysid.spread_degrees_of_freedom without scipy
    ("sysid.plan", "sysid._timing"),  # scipy for the bound only; sysid.synthetic imports sysid.plan
}


@pytest.fixture(scope="module")
def graph() -> tuple[dict[str, set[str]], list[house_metrics.LocalImport]]:
    return house_metrics.import_graph()


def _floor(module: str) -> str:
    return module.split(".")[0]


def test_each_floor_imports_only_the_floors_below(
    graph: tuple[dict[str, set[str]], list[house_metrics.LocalImport]],
) -> None:
    edges, _ = graph
    wrong = sorted(
        f"{m} -> {t}"
        for m, targets in edges.items()
        if _floor(m) in FLOORS
        for t in targets
        if _floor(t) != _floor(m) and _floor(t) not in MAY_IMPORT[_floor(m)]
    )
    assert wrong == []


def test_no_import_cycle_in_the_house(
    graph: tuple[dict[str, set[str]], list[house_metrics.LocalImport]],
) -> None:
    edges, _ = graph
    assert house_metrics.cycles(edges) == []
    assert house_metrics.cycles(house_metrics.package_edges(edges)) == []


def test_the_floors_import_at_the_top_but_for_the_named_few(
    graph: tuple[dict[str, set[str]], list[house_metrics.LocalImport]],
) -> None:
    _, local = graph
    found = {(i.module, i.target) for i in local if _floor(i.module) in FLOORS}
    assert found == DEFERRED


def test_floor_functions_are_short_and_no_line_is_dated() -> None:
    lengths = [(n, f) for n, f in house_metrics.function_lengths() if _floor(f) in FLOORS]
    assert max(lengths)[0] <= 100, max(lengths)
    assert sum(n <= 30 for n, _ in lengths) >= 0.9 * len(lengths)
    assert [d for d in house_metrics.dated_lines() if d.split("/")[0] in FLOORS] == []
