"""dynamics="plant": the foreign plant as the envs' world (single, vector, race), seeded."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from gymnasium.vector import SyncVectorEnv
from hypothesis import given, settings
from hypothesis import strategies as st

import sim2real.envs  # noqa: F401  (registers the ids)
from robots.randomization import DriveDistribution
from robots.spec import load_spec
from sim2real.envs import CrowdNavEnv, RaceEnv, RandomMapEnv, race_parallel_env
from sim2real.errors import Sim2RealValueError
from sim2real.plants.closed_loop import PlantSessions
from sim2real.plants.diff_drive import SessionVariation, plant_from_spec
from tests.sim2real.envs.test_envs_vector import assert_infos_equal

ENVS = {
    "RandomMap": lambda **kw: RandomMapEnv(preset="TEST1", **kw),
    "CrowdNav": lambda **kw: CrowdNavEnv(**kw),
    "Race": lambda **kw: RaceEnv(track="open", num_opponents=2, **kw),
}


def rollout(env: gym.Env[Any, Any], seed: int, steps: int) -> list[Any]:
    """Observations, rewards and outcomes of ``steps`` steps of a fixed action sequence."""
    obs, _ = env.reset(seed=seed)
    out: list[Any] = [obs]
    rng = np.random.default_rng(5)
    for _ in range(steps):
        a = rng.uniform(env.action_space.low, env.action_space.high).astype(np.float32)  # type: ignore[attr-defined]
        obs, r, term, trunc, info = env.step(a)
        out += [obs, r, info["outcome"]]
        if term or trunc:
            obs, _ = env.reset()
            out.append(obs)
    return out


def _equal(a: list[Any], b: list[Any]) -> bool:
    def flat(x: Any) -> Any:
        return np.concatenate([np.ravel(v) for v in x.values()]) if isinstance(x, dict) else x

    return all(np.array_equal(flat(x), flat(y)) for x, y in zip(a, b, strict=True))


@pytest.mark.parametrize("name", list(ENVS))
def test_check_env_passes_with_the_plant(name: str) -> None:
    env = ENVS[name](dynamics="plant")
    check_env(env, skip_render_check=True)
    env.close()


@settings(max_examples=4, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), name=st.sampled_from(sorted(ENVS)))
def test_same_seed_same_numbers_other_seed_other_session(seed: int, name: str) -> None:
    a, b = ENVS[name](dynamics="plant"), ENVS[name](dynamics="plant")
    assert _equal(rollout(a, seed, 40), rollout(b, seed, 40))
    backend = a.core.backends[0] if name == "Race" else a._backend
    a.reset(seed=seed)
    first = backend.session
    a.reset(seed=seed + 1)
    assert backend.session != first and backend.session.robot == first.robot


def test_each_episode_draws_a_session_from_np_random_after_the_world() -> None:
    env = RandomMapEnv(preset="TEST1", dynamics="plant")
    env.reset(seed=3)
    drawn = [env._backend.session]
    for _ in range(5):
        env.reset()
        drawn.append(env._backend.session)
    var, base = SessionVariation(), plant_from_spec("turtlebot3_burger")
    latencies = np.array([s.latency_s for s in drawn])
    payloads = np.array([s.mass_kg / base.mass_kg - 1.0 for s in drawn])
    assert np.unique(latencies).size == 6 and np.unique(payloads).size == 6
    assert np.all((latencies >= var.latency_s[0]) & (latencies <= var.latency_s[1]))
    assert np.all((payloads >= var.payload_fraction[0]) & (payloads <= var.payload_fraction[1]))
    # the map comes first from np_random: the same map as with the reduced model
    reduced = RandomMapEnv(preset="TEST1")
    reduced.reset(seed=3)
    env.reset(seed=3)
    np.testing.assert_array_equal(env.layout.cylinders, reduced.layout.cylinders)  # type: ignore[union-attr]


def test_a_fixed_session_is_the_same_plant_every_episode() -> None:
    fixed = plant_from_spec("turtlebot3_burger", latency_s=0.2)
    env = RandomMapEnv(preset="TEST1", dynamics="plant", plant_sessions=fixed)
    for seed in (0, 1):
        env.reset(seed=seed)
        assert env._backend.session is fixed


def test_the_plant_lags_the_drive_model_by_its_latency() -> None:
    # a long fixed latency: the plant has not moved after the first steps, the model has
    slow = plant_from_spec("turtlebot3_burger", latency_s=0.3, latency_jitter_s=0.0)
    plant = RandomMapEnv(preset="TEST1", dynamics="plant", plant_sessions=slow)
    model = RandomMapEnv(preset="TEST1")
    for env in (plant, model):
        env.reset(seed=0)
        for _ in range(3):
            obs, *_ = env.step(np.array([0.2, 0.0], np.float32))
        env.obs = obs  # type: ignore[attr-defined]
    assert plant.obs[38] == 0.0 and model.obs[38] > 0.05  # type: ignore[attr-defined]
    assert plant._backend.pose[:2] == pytest.approx(plant.layout.start_xy, abs=1e-9)  # type: ignore[union-attr]


def _assert_obs_equal(a: Any, b: Any, where: str) -> None:
    for key in b if isinstance(b, dict) else [None]:
        x, y = (a, b) if key is None else (a[key], b[key])
        np.testing.assert_array_equal(x, y, err_msg=f"observation {key or ''}, {where}")


@pytest.mark.parametrize("env_id", ["sim2real/RandomMap-v0", "sim2real/CrowdNav-v0"])
def test_native_vector_env_equals_single_envs_on_the_plant(env_id: str) -> None:
    kw: dict[str, Any] = {"dynamics": "plant", "max_episode_steps": 40}
    single = RandomMapEnv if "RandomMap" in env_id else CrowdNavEnv
    vec = gym.make_vec(env_id, num_envs=3, vectorization_mode="vector_entry_point", **kw)
    sync = SyncVectorEnv([lambda: single(**kw) for _ in range(3)])
    assert vec.unwrapped._plant  # type: ignore[attr-defined]
    ov, iv = vec.reset(seed=11)
    os_, is_ = sync.reset(seed=11)
    _assert_obs_equal(ov, os_, "reset")
    assert_infos_equal(iv, is_, "reset")
    rng = np.random.default_rng(2)
    space = sync.single_action_space
    ends = 0
    for t in range(90):
        actions = rng.uniform(space.low, space.high, (3, 2)).astype(np.float32)  # type: ignore[attr-defined]
        rv, rs = vec.step(actions), sync.step(actions)
        _assert_obs_equal(rv[0], rs[0], f"step {t}")
        np.testing.assert_allclose(rv[1], rs[1], rtol=1e-12, atol=1e-12)
        np.testing.assert_array_equal(rv[2] | rv[3], rs[2] | rs[3])
        assert_infos_equal(rv[4], rs[4], f"step {t}")
        ends += int((rv[2] | rv[3]).sum())
    assert ends >= 3  # autoresets drew new sessions
    vec.close()
    sync.close()


def test_race_parallel_env_gives_each_robot_its_session() -> None:
    env = race_parallel_env(n_robots=2, track="open", num_opponents=0, dynamics="plant")
    env.reset(seed=4)
    sessions = [b.session for b in env.core.backends]
    assert sessions[0] != sessions[1]


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (
            lambda: RandomMapEnv(plant_sessions=PlantSessions.of("turtlebot2")),
            "plant_sessions drive dynamics='plant' only",
        ),
        (
            lambda: RandomMapEnv(dynamics="plant", plant_sessions=PlantSessions.of("turtlebot2")),
            "sessions of robot 'turtlebot2' but the env drives 'turtlebot3_burger'",
        ),
        (
            lambda: RaceEnv(dynamics="plant", plant_sessions=plant_from_spec("turtlebot2")),
            "sessions of robot 'turtlebot2'",
        ),
        (
            lambda: CrowdNavEnv(dynamics="plant", plant_sessions=3),
            "plant_sessions must be a sim2real.plants.PlantSessions or PlantParams, got int",
        ),
        (
            lambda: RandomMapEnv(
                dynamics="plant",
                drive_distribution=DriveDistribution.from_priors(
                    "turtlebot3_burger",
                    load_spec("turtlebot3_burger").geometry,
                    load_spec("turtlebot3_burger").priors,
                ),
            ),
            "drive_distribution randomises the drive model",
        ),
        (lambda: RandomMapEnv(dynamics="plants"), "or 'plant' \\(a foreign base"),
    ],
)
def test_bad_plant_input_is_one_sentence(make: Any, match: str) -> None:
    with pytest.raises(Sim2RealValueError, match=match) as info:
        make()
    assert str(info.value).count(". ") == 0


def test_drive_params_cannot_be_set_on_the_plant() -> None:
    env = RandomMapEnv(dynamics="plant")
    assert env.get_drive_params() == load_spec("turtlebot3_burger").drive
    with pytest.raises(Sim2RealValueError, match="does not apply to dynamics='plant'"):
        env.set_drive_params(env.get_drive_params())


def test_a_training_config_on_the_plant_is_refused_its_evaluation_is_not() -> None:
    from sim2real.training.config import config_from_dict

    env = {"id": "sim2real/RandomMap-v0", "kwargs": {"dynamics": "plant"}}
    with pytest.raises(Sim2RealValueError, match="is never trained on; train with dynamics"):
        config_from_dict({"env": env})
    ok = config_from_dict(
        {"env": "sim2real/RandomMap-v0", "evaluation": {"kwargs": {"dynamics": "plant"}}}
    )
    assert ok.eval_kwargs["dynamics"] == "plant"
