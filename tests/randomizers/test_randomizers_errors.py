"""One test per bad argument: the error class, and a message naming argument, rule and value."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import pytest
from randomizers_testenv import NavDouble

from randomizers import (
    ActionDelay,
    CameraPoseJitter,
    DepthNoise,
    DynamicsRandomizer,
    GoalNoise,
    LidarNoise,
    ObservationNoise,
    OdometryDelay,
    SuccessRateCurriculum,
)
from randomizers.errors import (
    MissingObservationKeyError,
    MissingProtocolError,
    RandomizerError,
    RandomizerTypeError,
    RandomizerValueError,
)

DEPTH = {"near_m": 0.05, "far_m": 8.0, "key": "depth"}


def cartpole() -> gym.Env[Any, Any]:
    return gym.make("CartPole-v1")


def taxi() -> gym.Env[Any, Any]:
    return gym.make("FrozenLake-v1")  # Discrete observations


CASES = [
    # (factory, error class, builtin, fragments the message must contain)
    (
        lambda: DepthNoise(NavDouble(), -0.2, **DEPTH),
        RandomizerValueError,
        ValueError,
        ["std_m", ">= 0", "-0.2"],
    ),
    (
        lambda: DepthNoise(NavDouble(), 0.2, near_m=0.05, far_m=0.01, key="depth"),
        RandomizerValueError,
        ValueError,
        ["far_m", "near_m", "0.01"],
    ),
    (
        lambda: DepthNoise(NavDouble(), 0.2, near_m=-1.0, far_m=8.0, key="depth"),
        RandomizerValueError,
        ValueError,
        ["near_m", "-1.0"],
    ),
    (
        lambda: DepthNoise(NavDouble(), "0.2", **DEPTH),
        RandomizerTypeError,
        TypeError,
        ["std_m", "number", "'0.2'"],
    ),
    (
        lambda: DepthNoise(NavDouble(), float("nan"), **DEPTH),
        RandomizerValueError,
        ValueError,
        ["std_m", "finite", "nan"],
    ),
    (
        lambda: DepthNoise(NavDouble(), 0.2, near_m=0.05, far_m=8.0, key="rgb"),
        MissingObservationKeyError,
        KeyError,
        ["'rgb'", "depth", "lidar", "goal", "velocity"],
    ),
    (
        lambda: DepthNoise(NavDouble(), 0.2, near_m=0.05, far_m=8.0),
        RandomizerValueError,
        ValueError,
        ["'key'", "required", "depth"],
    ),
    (
        lambda: DepthNoise(cartpole(), 0.2, near_m=0.05, far_m=8.0, key="depth"),
        RandomizerTypeError,
        TypeError,
        ["'key'", "Dict", "Box"],
    ),
    (
        lambda: DepthNoise(NavDouble(), 0.2, scale=1.5, **DEPTH),
        RandomizerValueError,
        ValueError,
        ["scale", "[0, 1]", "1.5"],
    ),
    (
        lambda: DepthNoise(NavDouble(), 0.2, scale=-0.1, **DEPTH),
        RandomizerValueError,
        ValueError,
        ["scale", "[0, 1]", "-0.1"],
    ),
    (lambda: ObservationNoise(taxi(), 0.1), RandomizerTypeError, TypeError, ["Box", "Discrete"]),
    (
        lambda: ObservationNoise(cartpole(), [0.1, 0.2]),
        RandomizerValueError,
        ValueError,
        ["std", "2 entries", "4 elements"],
    ),
    (
        lambda: ObservationNoise(cartpole(), 0.1, index=7),
        RandomizerValueError,
        ValueError,
        ["index", "7", "[0, 4)"],
    ),
    (
        lambda: ObservationNoise(cartpole(), 0.1, index=slice(0, 4, 2)),
        RandomizerValueError,
        ValueError,
        ["index", "step 1"],
    ),
    (
        lambda: ObservationNoise(cartpole(), 0.1, index="a"),
        RandomizerTypeError,
        TypeError,
        ["index", "'a'"],
    ),
    (
        lambda: ObservationNoise(cartpole(), 0.1, name=""),
        RandomizerTypeError,
        TypeError,
        ["name", "non-empty"],
    ),
    (
        lambda: LidarNoise(NavDouble(), 0.01, dropout=1.5, key="lidar"),
        RandomizerValueError,
        ValueError,
        ["dropout", "[0, 1]", "1.5"],
    ),
    (
        lambda: LidarNoise(NavDouble(), -0.01, key="lidar"),
        RandomizerValueError,
        ValueError,
        ["std_m", "-0.01"],
    ),
    (
        lambda: LidarNoise(cartpole(), 0.01, index=[0, 2]),
        RandomizerValueError,
        ValueError,
        ["range_min_m", "required"],
    ),
    (
        lambda: GoalNoise(NavDouble(), -1.0, key="goal"),
        RandomizerValueError,
        ValueError,
        ["std_m", "-1.0"],
    ),
    (
        lambda: GoalNoise(NavDouble(), key="goal", coords="spherical"),
        RandomizerValueError,
        ValueError,
        ["coords", "cartesian", "polar", "'spherical'"],
    ),
    (
        lambda: GoalNoise(NavDouble(), key="goal", resample="always"),
        RandomizerValueError,
        ValueError,
        ["resample", "episode", "'always'"],
    ),
    (
        lambda: GoalNoise(NavDouble(), key="lidar", coords="polar"),
        RandomizerValueError,
        ValueError,
        ["polar", "exactly 2", "36"],
    ),
    (
        lambda: OdometryDelay(NavDouble(), delay_steps=-1, key="velocity"),
        RandomizerValueError,
        ValueError,
        ["delay_steps", ">= 0", "-1"],
    ),
    (
        lambda: OdometryDelay(NavDouble(), delay_s=-0.1, key="velocity"),
        RandomizerValueError,
        ValueError,
        ["delay_s", ">= 0", "-0.1"],
    ),
    (
        lambda: OdometryDelay(NavDouble(), delay_steps=1.5, key="velocity"),
        RandomizerTypeError,
        TypeError,
        ["delay_steps", "whole number", "1.5"],
    ),
    (
        lambda: OdometryDelay(NavDouble(), delay_steps=[3, 1], key="velocity"),
        RandomizerValueError,
        ValueError,
        ["delay_steps", "low <= high", "[3, 1]"],
    ),
    (
        lambda: OdometryDelay(NavDouble(), key="velocity"),
        RandomizerValueError,
        ValueError,
        ["exactly one", "delay_s", "delay_steps"],
    ),
    (
        lambda: OdometryDelay(NavDouble(), delay_s=0.1, delay_steps=1, key="velocity"),
        RandomizerValueError,
        ValueError,
        ["exactly one"],
    ),
    (
        lambda: OdometryDelay(NavDouble(), delay_steps=1, key="velocity", fill="nan"),
        RandomizerValueError,
        ValueError,
        ["fill", "first", "'nan'"],
    ),
    (
        lambda: OdometryDelay(cartpole(), delay_s=0.1, index=1),
        MissingProtocolError,
        AttributeError,
        ["control_dt", "CartPoleEnv", "dt_s"],
    ),
    (
        lambda: ActionDelay(cartpole(), delay_s=0.1, dt_s=0.0),
        RandomizerValueError,
        ValueError,
        ["dt_s", "> 0", "0.0"],
    ),
    (
        lambda: ActionDelay(cartpole(), delay_steps=-2),
        RandomizerValueError,
        ValueError,
        ["delay_steps", "-2"],
    ),
    (
        lambda: CameraPoseJitter(NavDouble(), position_std_m=-0.01),
        RandomizerValueError,
        ValueError,
        ["position_std_m", "-0.01"],
    ),
    (
        lambda: CameraPoseJitter(NavDouble(), orientation_std_deg=-2),
        RandomizerValueError,
        ValueError,
        ["orientation_std_deg", "deg", "-2"],
    ),
    (
        lambda: CameraPoseJitter(cartpole()),
        MissingProtocolError,
        AttributeError,
        ["set_camera_pose", "CartPoleEnv"],
    ),
    (
        lambda: DynamicsRandomizer(NavDouble()),
        RandomizerValueError,
        ValueError,
        ["uniform", "normal"],
    ),
    (
        lambda: DynamicsRandomizer(NavDouble(), uniform={"friction": [0, 1]}),
        RandomizerValueError,
        ValueError,
        ["uniform", "'friction'", "coulomb_v_fwd_n"],
    ),
    (
        lambda: DynamicsRandomizer(NavDouble(), uniform={"delay_s": [0.2, 0.1]}),
        RandomizerValueError,
        ValueError,
        ["uniform", "delay_s", "low <= high"],
    ),
    (
        lambda: DynamicsRandomizer(NavDouble(), normal={"delay_s": [0.1, -0.01]}),
        RandomizerValueError,
        ValueError,
        ["normal", "delay_s", "std", "-0.01"],
    ),
    (
        lambda: DynamicsRandomizer(NavDouble(), normal={"delay_s": 0.1}),
        RandomizerValueError,
        ValueError,
        ["normal", "delay_s", "[mean, std]"],
    ),
    (
        lambda: DynamicsRandomizer(
            NavDouble(), uniform={"delay_s": [0, 1]}, normal={"delay_s": [0, 1]}
        ),
        RandomizerValueError,
        ValueError,
        ["both", "delay_s"],
    ),
    (
        lambda: DynamicsRandomizer(NavDouble(), uniform={"delay_s": [0, 1]}, scale=2),
        RandomizerValueError,
        ValueError,
        ["scale", "2"],
    ),
    (
        lambda: DynamicsRandomizer(cartpole(), uniform={"delay_s": [0, 1]}),
        MissingProtocolError,
        AttributeError,
        ["get_drive_params", "CartPoleEnv"],
    ),
    (
        lambda: SuccessRateCurriculum(ObservationNoise(cartpole()), threshold=1.2),
        RandomizerValueError,
        ValueError,
        ["threshold", "1.2"],
    ),
    (
        lambda: SuccessRateCurriculum(ObservationNoise(cartpole()), window=0),
        RandomizerValueError,
        ValueError,
        ["window", "0"],
    ),
    (
        lambda: SuccessRateCurriculum(ObservationNoise(cartpole()), increment=0.0),
        RandomizerValueError,
        ValueError,
        ["increment", "0"],
    ),
]


@pytest.mark.parametrize(("make", "error", "builtin", "fragments"), CASES)
def test_bad_argument(make, error, builtin, fragments) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(error) as info:
        make()
    assert isinstance(info.value, RandomizerError) and isinstance(info.value, builtin)
    text = str(info.value)
    for fragment in fragments:
        assert fragment in text, f"{fragment!r} not in {text!r}"
    assert "\n" not in text and not text.startswith("'")


def test_set_scale_out_of_range() -> None:
    env = ObservationNoise(cartpole(), 0.1)
    with pytest.raises(RandomizerValueError, match=r"'scale' must be in \[0, 1\].*1.01"):
        env.set_scale(1.01)
    assert env.scale == 1.0
