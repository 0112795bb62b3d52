"""The whole house keeps the rules that scripts/house_metrics.py measures: sim2real's rooms import
only the rooms their docstrings allow, imports inside functions are a short named list, functions
are short and no line of package code carries a date. (tests/test_floors.py holds the lower
floors to the same rules and checks that no import cycle exists anywhere.)"""

from __future__ import annotations

import statistics
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
import house_metrics

Graph = tuple[dict[str, set[str]], list[house_metrics.LocalImport]]

#: What each room of sim2real may import of the project (its own room aside). The CLI composes
#: everything; the library rooms never import the CLI, and nothing below training imports it.
LIBRARY = {"sim2real.errors", "sim2real._io", "sim2real._arrays", "robots", "sysid", "randomizers"}
MAY_IMPORT = {
    "sim2real": set(),
    "sim2real.__main__": {"sim2real.cli"},
    "sim2real.errors": set(),
    "sim2real._arrays": {"robots"},
    "sim2real._io": {"robots", "sim2real.errors"},
    "sim2real.logs": {"robots", "sim2real._io", "sim2real._arrays", "sim2real.errors"},
    "sim2real.plants": {"robots", "sysid", "sim2real._arrays", "sim2real.errors", "sim2real.logs"},
    "sim2real._samples": {"sim2real.logs", "sim2real.plants"},
    "sim2real.fitting": LIBRARY | {"sim2real.logs"},
    "sim2real.planning": LIBRARY | {"sim2real.logs"},
    "sim2real.sensor_id": LIBRARY | {"sim2real.logs"},
    "sim2real.sensor_report": LIBRARY | {"sim2real.envs"},  # the sim lidar is the envs' ray caster
    "sim2real.mujoco": {"robots", "sim2real.errors"},
    "sim2real.agreement": LIBRARY | {"sim2real.logs", "sim2real.mujoco"},
    "sim2real.cluster": LIBRARY | {"sim2real.logs", "sim2real.agreement"},
    "sim2real.envs": LIBRARY | {"sim2real.plants", "sim2real.mujoco"},
    "sim2real.training": LIBRARY | {"sim2real.envs", "sim2real.cluster"},
}

#: Imports written inside sim2real's functions: optional extras (Ray, RLlib, stable-baselines3
#: through training's own modules) and heavy packages a light command must not load
#: (tests/sim2real/test_import_budget.py). A new one belongs here, with its reason, or at the top.
DEFERRED = {
    ("sim2real", "importlib.metadata"),  # __version__ only when asked for
    ("sim2real.agreement.figures", "randomizers._dynamics"),  # gymnasium, for ensembles only
    ("sim2real.agreement.replay", "robots.pybullet_robot"),  # the pybullet engine only
    ("sim2real.agreement.report._plots", "matplotlib.backends.backend_agg"),
    ("sim2real.agreement.report._plots", "matplotlib.figure"),
    ("sim2real.cli._progress", "rich.console"),  # progress bars on long work only
    ("sim2real.cli._progress", "rich.progress"),
    ("sim2real.cluster", "ray"),  # the [cluster] extra
    ("sim2real.cluster", "ray._private"),
    ("sim2real.envs._car", "pybullet"),  # reduced-dynamics envs load no pybullet
    ("sim2real.envs._robot", "robots.pybullet_robot"),
    ("sim2real.envs._world", "robots"),
    ("sim2real.envs.depth", "robots._pybullet"),
    ("sim2real.logs._bags", "rosbags.rosbag1"),  # ROS 1 bags and rosbag2 folders only
    ("sim2real.logs._bags", "rosbags.rosbag2"),
    ("sim2real.logs._channels", "difflib"),  # "did you mean" only on a missing topic
    ("sim2real.logs._decode", "mcap.records"),  # off the fast MCAP read path
    ("sim2real.logs._decode", "mcap_ros2.decoder"),
    ("sim2real.logs._decode", "rosbags.typesys"),
    ("sim2real.logs._decode", "json"),
    ("sim2real.logs._digest", "hashlib"),
    ("sim2real.logs._mcap", "zstandard"),  # compressed chunks only
    ("sim2real.logs._mcap", "lz4.frame"),
    ("sim2real.logs._reader", "sim2real.logs._csv"),  # CSV traces only
    ("sim2real.logs._writer", "mcap.writer"),
    ("sim2real.training.config", "ray.rllib"),  # the [rllib] extra
    ("sim2real.training.evaluation", "sim2real.training"),  # _sb3 / _rllib: the [train] extra
    ("sim2real.training.train", "sim2real.training"),
}
MAX_DEFERRED = 40


@pytest.fixture(scope="module")
def graph() -> Graph:
    return house_metrics.import_graph()


def _room(module: str) -> str:
    parts = module.split(".")
    if parts[0] != "sim2real":
        return parts[0]
    return ".".join(parts[:2])


def test_each_room_imports_only_what_it_may(graph: Graph) -> None:
    edges, _ = graph
    wrong = sorted(
        f"{m} -> {t}"
        for m, targets in edges.items()
        if _room(m).startswith("sim2real") and _room(m) != "sim2real.cli"
        for t in targets
        if _room(t) != _room(m) and _room(t) not in MAY_IMPORT.get(_room(m), set())
    )
    assert wrong == []


def test_no_library_module_imports_the_cli(graph: Graph) -> None:
    edges, _ = graph
    wrong = sorted(
        f"{m} -> {t}"
        for m, targets in edges.items()
        if _room(m) not in {"sim2real.cli", "sim2real.__main__"}
        for t in targets
        if _room(t) == "sim2real.cli"
    )
    assert wrong == []


def test_imports_inside_functions_are_the_named_list(graph: Graph) -> None:
    _, local = graph
    found = {
        (item.module, item.target) for item in local if item.module.split(".")[0] == "sim2real"
    }
    assert found - DEFERRED == set(), "name it in DEFERRED with its reason, or move it to the top"
    assert len(local) <= MAX_DEFERRED


def test_functions_are_short() -> None:
    lengths = [n for n, _ in house_metrics.function_lengths()]
    longest = max(house_metrics.function_lengths())
    assert longest[0] <= 100, longest
    assert statistics.quantiles(lengths, n=10)[-1] <= 30


def test_no_dated_line_in_package_code() -> None:
    assert house_metrics.dated_lines() == []


def test_the_rooms_table_knows_every_room() -> None:
    rooms = {_room(m) for m in house_metrics.modules() if m.startswith("sim2real")}
    assert rooms - set(MAY_IMPORT) - {"sim2real.cli"} == set()
