"""Build stacks from YAML, write them back (round trip) and rebuild them from env.spec."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml
from randomizers_testenv import ENV_ID, FULL_STACK, NavDouble

import randomizers
from randomizers import ActionDelay, ObservationNoise, OdometryDelay
from randomizers.errors import MissingObservationKeyError, RandomizerConfigError


def test_from_config_builds_innermost_first() -> None:
    env = randomizers.from_config(NavDouble(), FULL_STACK)
    names = [r.name for r in randomizers.iter_randomizers(env)]
    assert names[-1] == "DynamicsRandomizer" and names[0] == "ObservationNoise[velocity]"
    assert len(names) == 8


def test_yaml_round_trip_preserves_stack_scale_and_streams(tmp_path: Path) -> None:
    path = tmp_path / "dr.yaml"
    path.write_text(yaml.safe_dump(FULL_STACK), encoding="utf-8")
    env = randomizers.from_config(NavDouble(), path)
    randomizers.set_scale(env, 0.5)
    saved = randomizers.save_config(env, tmp_path / "out.yaml")
    doc = yaml.safe_load(saved.read_text(encoding="utf-8"))
    assert doc["format"] == "sim2real.randomizers/1"
    assert [e["type"] for e in doc["randomizers"]] == [e["type"] for e in FULL_STACK["randomizers"]]
    assert all(e["scale"] == 0.5 for e in doc["randomizers"])
    rebuilt = randomizers.from_config(NavDouble(), saved)
    assert randomizers.to_config(rebuilt) == doc
    a, _ = env.reset(seed=3)
    b, _ = rebuilt.reset(seed=3)
    for key in a:
        np.testing.assert_array_equal(a[key], b[key])
    assert not list(tmp_path.glob(".*.tmp"))  # no temp file left behind


def test_to_config_records_normalised_arguments() -> None:
    env = OdometryDelay(gym.make("CartPole-v1"), delay_steps=(1, 3), index=slice(1, 2))
    entry = randomizers.to_config(env)["randomizers"][0]
    assert entry == {
        "type": "OdometryDelay",
        "delay_s": None,
        "delay_steps": [1, 3],
        "key": None,
        "index": [1, 2],
        "fill": "first",
        "dt_s": None,
        "scale": 1.0,
        "name": "OdometryDelay[1:2]",
    }
    yaml.safe_dump(randomizers.to_config(env))  # plain YAML types only


def test_stack_rebuilds_from_env_spec() -> None:
    env = ObservationNoise(ActionDelay(gym.make("CartPole-v1"), delay_steps=2), std=0.05)
    env.set_scale(0.25)
    spec = env.spec
    assert spec is not None
    assert [w.entry_point for w in spec.additional_wrappers] == [
        "randomizers:ActionDelay",
        "randomizers:ObservationNoise",
    ]
    assert spec.additional_wrappers[-1].kwargs["scale"] == 0.25
    again = gym.make(spec)
    assert randomizers.to_config(again) == randomizers.to_config(env)
    randomizers.set_scale(env, 0.75)  # stack-level: outer wrappers' cached specs are dropped
    assert {w.kwargs["scale"] for w in env.spec.additional_wrappers} == {0.75}


def test_registered_test_env_with_make_and_config() -> None:
    env = randomizers.from_config(gym.make(ENV_ID), FULL_STACK)
    obs, _ = env.reset(seed=0)
    assert set(obs) == {"depth", "lidar", "goal", "velocity"}


@pytest.mark.parametrize(
    ("config", "match"),
    [
        ({"format": "other/2", "randomizers": []}, "key 'format'"),
        ({"randomizers": {"type": "DepthNoise"}}, "must be a list"),
        ({"randomizers": [{"std": 0.1}]}, "'type' key"),
        ({"randomizers": [{"type": "Blur"}]}, "unknown type 'Blur'"),
        ({"randomizers": [{"type": "GoalNoise", "key": "goal", "sigma": 1}]}, "sigma"),
    ],
)
def test_bad_config_is_a_clear_error(config: dict, match: str) -> None:  # type: ignore[type-arg]
    with pytest.raises(RandomizerConfigError, match=match):
        randomizers.from_config(NavDouble(), config)


def test_config_error_from_a_wrapper_names_the_entry() -> None:
    config = {"randomizers": [{"type": "GoalNoise", "key": "target"}]}
    with pytest.raises(MissingObservationKeyError, match=r"randomizers\[0\] \(GoalNoise\).*target"):
        randomizers.from_config(NavDouble(), config)


def test_missing_and_invalid_files(tmp_path: Path) -> None:
    with pytest.raises(RandomizerConfigError, match="does not exist"):
        randomizers.from_config(NavDouble(), tmp_path / "none.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("randomizers: [", encoding="utf-8")
    with pytest.raises(RandomizerConfigError, match="not valid YAML"):
        randomizers.from_config(NavDouble(), bad)
    with pytest.raises(RandomizerConfigError, match="does not exist"):
        randomizers.save_config(NavDouble(), tmp_path / "no" / "dir.yaml")


@pytest.mark.parametrize(
    ("text", "where"),
    [
        ("randomizers:\n  - type: GoalNoise\n   bad: [1\n", "at line 3, column"),
        ("format: x\n a: b: c\n", "at line 2, column"),
        ("\xff\xfe not utf-8", "('utf-8' codec"),
    ],
)
def test_invalid_yaml_is_one_line_naming_file_place_and_fix(
    tmp_path: Path, text: str, where: str
) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_bytes(text.encode("latin-1"))
    with pytest.raises(RandomizerConfigError) as info:
        randomizers.from_config(NavDouble(), bad)
    message = str(info.value)
    assert "\n" not in message and "^" not in message  # no YAML snippet with a caret
    assert message.startswith(f"randomizer config '{bad}' is not valid YAML {where}")
    assert message.endswith(
        "fix the syntax there, or write the file again with randomizers.save_config"
    )
