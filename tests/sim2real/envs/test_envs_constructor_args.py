"""Every env refuses out-of-range constructor arguments with one sentence (no traceback).

RaceEnv and race_parallel_env divided by ``control_dt`` before checking it (ZeroDivisionError for
0, ValueError for NaN) and took any ``drive_params`` (AttributeError deep in the robot).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import pytest

from sim2real.envs.car_crossing import CarCrossingEnv
from sim2real.envs.race import RaceEnv, race_parallel_env
from sim2real.envs.random_map import RandomMapEnv
from sim2real.errors import Sim2RealValueError

ENVS: dict[str, Callable[..., Any]] = {
    "RandomMapEnv": RandomMapEnv,
    "CarCrossingEnv": CarCrossingEnv,
    "RaceEnv": RaceEnv,
    "race_parallel_env": race_parallel_env,
}

CASES = [
    ({"dynamics": "ode"}, "dynamics (--dynamics) must be one of reduced, pybullet"),
    ({"control_dt": 0.0}, "control_dt must be a finite number of seconds > 0, got 0.0"),
    ({"control_dt": math.nan}, "control_dt must be a finite number of seconds > 0, got nan"),
    ({"control_dt": -0.1}, "control_dt must be a finite number of seconds > 0, got -0.1"),
    ({"max_episode_steps": 0}, "max_episode_steps must be an integer >= 1, got 0"),
    ({"max_episode_steps": 2.5}, "max_episode_steps must be an integer >= 1, got 2.5"),
    ({"drive_params": "fast"}, "drive_params must be a robots.DriveParams, got str"),
]


@pytest.mark.parametrize("name", list(ENVS))
@pytest.mark.parametrize(("kwargs", "message"), CASES)
def test_bad_constructor_argument_is_one_sentence(
    name: str, kwargs: dict[str, Any], message: str
) -> None:
    with pytest.raises(Sim2RealValueError) as info:
        ENVS[name](**kwargs)
    assert str(info.value).startswith(message)


def test_the_pybullet_hint_names_what_each_env_simulates() -> None:
    with pytest.raises(Sim2RealValueError, match=r"'pybullet' \(rigid-body car\)"):
        CarCrossingEnv(dynamics="ode")
    with pytest.raises(Sim2RealValueError, match=r"'pybullet' \(full rigid-body robot\)"):
        RaceEnv(dynamics="ode")
