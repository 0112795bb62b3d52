"""A seeded episode of a pybullet env does not depend on the episodes before it.

``env.reset(seed=s)`` after other episodes gives, bit for bit, the episode of a fresh env's
``reset(seed=s)`` with the same actions: observations, rewards and the bodies' poses. The envs
get there by rebuilding their pybullet world at every reset (``PybulletWorld.reset_simulation``,
then a new robot body): pybullet's contact points and their warm-start impulses would otherwise
carry over (see tests/robots/test_robots_pybullet_reset.py for a robot's own ``reset``).
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import sim2real.envs  # noqa: F401  (registers the ids)

ENVS: dict[str, dict[str, Any]] = {
    "sim2real/RandomMap-v0": {},
    "sim2real/CrowdNav-v0": {},
    "sim2real/CarCrossing-v0": {},
    "sim2real/Race-v0": {"track": "curve", "num_opponents": 3},
}


def _flat(obs: Any) -> np.ndarray:
    if isinstance(obs, dict):
        return np.concatenate([np.asarray(obs[k], dtype=np.float64).ravel() for k in sorted(obs)])
    return np.asarray(obs, dtype=np.float64).ravel()


def _poses(env: Any) -> list[float]:
    """The pybullet poses of the robots (or the car) now."""
    if hasattr(env, "car"):
        return list(env.car.pose)
    if hasattr(env, "core"):
        return [q for b in env.core.backends for q in b.pose]
    return list(env._backend.pose)


def _episode(env: Any, seed: int, steps: int = 30) -> list[np.ndarray]:
    """Observation, reward and poses per step, with actions drawn from ``seed``."""
    obs, _ = env.reset(seed=seed)
    rows = [np.concatenate([_flat(obs), _poses(env)])]
    rng = np.random.default_rng(seed)
    space = env.action_space
    for _ in range(steps):
        if isinstance(space, gym.spaces.Discrete):
            action: Any = int(rng.integers(space.n))
        else:
            action = (space.low + (space.high - space.low) * rng.uniform(0.3, 1.0, 2)).astype(
                np.float32
            )
        obs, reward, terminated, truncated, _ = env.step(action)
        rows.append(np.concatenate([_flat(obs), [reward], _poses(env)]))
        if terminated or truncated:
            break
    return rows


@pytest.mark.parametrize("env_id", list(ENVS))
def test_a_seeded_episode_equals_a_fresh_envs(env_id: str) -> None:
    fresh = gym.make(env_id, dynamics="pybullet", **ENVS[env_id]).unwrapped
    try:
        want = _episode(fresh, seed=5)
    finally:
        fresh.close()
    env = gym.make(env_id, dynamics="pybullet", **ENVS[env_id]).unwrapped
    try:
        _episode(env, seed=1)
        _episode(env, seed=5, steps=1)  # ends ~1-2 cm from the start: contacts would persist
        got = _episode(env, seed=5)
    finally:
        env.close()
    assert len(want) >= 10  # the episode ran (CarCrossing's may end in a collision early)
    assert len(got) == len(want)
    start, end = np.array(want[0][-3:]), np.array(want[-1][-3:])
    assert np.hypot(*(end[:2] - start[:2])) > 0.05  # the robot (the car) moved, m
    for k, (a, b) in enumerate(zip(got, want, strict=True)):
        np.testing.assert_array_equal(a, b, err_msg=f"step {k}")
