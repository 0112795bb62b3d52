"""Native vector envs: the same numbers as N single envs, gymnasium's vector API, bad input."""

from __future__ import annotations

import os
import subprocess
import sys
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode, SyncVectorEnv
from gymnasium.vector.utils import batch_space
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import sim2real.envs  # noqa: F401  (registers the ids)
from robots.spec import load_spec
from sim2real.envs import RandomMapEnv, RandomMapVectorEnv
from sim2real.errors import Sim2RealValueError


def make_pair(n: int, **kw: Any) -> tuple[Any, SyncVectorEnv]:
    """The native vector env and gymnasium's SyncVectorEnv over the single env, same args."""
    vec = gym.make_vec(
        "sim2real/RandomMap-v0", num_envs=n, vectorization_mode="vector_entry_point", **kw
    )
    sync = SyncVectorEnv([lambda: RandomMapEnv(**kw) for _ in range(n)])
    return vec, sync


def assert_infos_equal(a: dict[str, Any], b: dict[str, Any], where: str) -> None:
    """Same keys and masks; same values where a sub-env has the key (NaN equals NaN)."""
    assert sorted(a) == sorted(b), f"{where}: info keys {sorted(a)} vs {sorted(b)}"
    for key in a:
        if key.startswith("_"):
            np.testing.assert_array_equal(a[key], b[key], err_msg=f"{where}: mask {key}")
            continue
        if isinstance(a[key], dict):
            assert_infos_equal(a[key], b[key], f"{where}/{key}")
            continue
        mask = a["_" + key]
        x, y = a[key][mask], b[key][mask]
        assert a[key].dtype == b[key].dtype, f"{where}: dtype of {key}"
        if x.dtype == object:
            assert list(x) == list(y), f"{where}: {key}"
        else:
            np.testing.assert_allclose(
                x, y, rtol=1e-12, atol=1e-12, equal_nan=True, err_msg=f"{where}: {key}"
            )


def run_both(vec: Any, sync: SyncVectorEnv, steps: int, seed: int, rng_seed: int) -> np.ndarray:
    """Step both with the same random actions; assert equal results; return end counts."""
    ov, iv = vec.reset(seed=seed)
    os_, is_ = sync.reset(seed=seed)
    np.testing.assert_array_equal(ov, os_)
    assert_infos_equal(iv, is_, "reset")
    rng = np.random.default_rng(rng_seed)
    space = sync.single_action_space
    ends = np.zeros(3, dtype=int)  # terminated, truncated, autoresets
    for t in range(steps):
        actions = rng.uniform(space.low, space.high, (vec.num_envs, 2)).astype(np.float32)
        rv = vec.step(actions)
        rs = sync.step(actions)
        np.testing.assert_array_equal(rv[0], rs[0], err_msg=f"observation, step {t}")
        np.testing.assert_allclose(rv[1], rs[1], rtol=1e-12, atol=1e-12, err_msg=f"reward {t}")
        np.testing.assert_array_equal(rv[2], rs[2], err_msg=f"terminated, step {t}")
        np.testing.assert_array_equal(rv[3], rs[3], err_msg=f"truncated, step {t}")
        assert_infos_equal(rv[4], rs[4], f"step {t}")
        assert rv[1].dtype == np.float64 and rv[2].dtype == np.bool_
        stepped = rv[4].get("_clearance_m", np.zeros(vec.num_envs, dtype=bool))
        ends += [rv[2].sum(), rv[3].sum(), int((~stepped).sum())]
    return ends


def test_vector_env_equals_n_single_envs_over_episodes_and_autoresets() -> None:
    # short episodes: collisions (terminated), traps (truncated) and autoresets all occur
    vec, sync = make_pair(4, preset="TEST4", max_episode_steps=120)
    ends = run_both(vec, sync, steps=500, seed=7, rng_seed=1)
    assert ends[0] >= 3 and ends[1] >= 3 and ends[2] >= 6, ends
    vec.close()
    sync.close()


def test_vector_env_equals_single_envs_with_a_short_goal_range() -> None:
    vec, sync = make_pair(2, preset="TEST1", max_episode_steps=60, goal_range_m=2.5)
    assert vec.single_observation_space.high[36] == np.float32(2.5)
    run_both(vec, sync, steps=80, seed=5, rng_seed=3)
    vec.close()
    sync.close()


def test_vector_env_equals_single_envs_with_the_goal_speed_reward() -> None:
    """The goal-speed term (a cost on |v| near the goal) enters both envs' rewards alike."""
    reward = {"goal_speed_per_mps": 3.0, "goal_speed_radius_m": 30.0}
    vec, sync = make_pair(2, preset="TEST1", max_episode_steps=60, reward=reward)
    run_both(vec, sync, steps=80, seed=5, rng_seed=3)
    vec.close()
    sync.close()


def test_vector_env_equals_single_envs_with_per_env_drive_params() -> None:
    """Different robots per sub-env (a long delay grows the command history) stay equal."""
    base = load_spec("turtlebot3_burger").drive
    params = [base.replace(delay_s=d, coulomb_v_fwd_n=c) for d, c in ((0.0, 0.5), (5.0, 2.0))]
    vec, sync = make_pair(2, preset="TEST1", max_episode_steps=300)
    vec.unwrapped.set_drive_params(params)
    for env, p in zip(sync.envs, params, strict=True):
        env.unwrapped.set_drive_params(p)
    assert vec.unwrapped.get_drive_params() == tuple(params)
    run_both(vec, sync, steps=320, seed=3, rng_seed=2)


def test_make_vec_gives_the_native_env_with_batched_spaces() -> None:
    envs = gym.make_vec(
        "sim2real/RandomMap-v0", num_envs=3, vectorization_mode="vector_entry_point"
    )
    base = envs.unwrapped
    assert isinstance(base, RandomMapVectorEnv)
    assert envs.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
    assert envs.num_envs == 3
    assert envs.observation_space == batch_space(envs.single_observation_space, 3)
    assert envs.action_space == batch_space(envs.single_action_space, 3)
    assert envs.single_observation_space == RandomMapEnv().observation_space
    obs, info = envs.reset(seed=0)
    assert obs.shape == (3, 40) and obs.dtype == np.float32
    assert envs.observation_space.contains(obs)
    obs, rew, term, trunc, info = envs.step(envs.action_space.sample())
    assert envs.observation_space.contains(obs)
    assert rew.shape == term.shape == trunc.shape == (3,)
    assert info["_outcome"].all() and info["preset"].tolist() == ["TRAIN"] * 3
    assert base.control_dt == 0.1
    envs.close()


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**31 - 10), n=st.integers(1, 4))
def test_seeding_is_per_sub_env_and_reproducible(seed: int, n: int) -> None:
    a = RandomMapVectorEnv(num_envs=n, preset="TEST1")
    b = RandomMapVectorEnv(num_envs=n, preset="TEST1")
    oa, _ = a.reset(seed=seed)
    ob, _ = b.reset(seed=seed)
    np.testing.assert_array_equal(oa, ob)
    for i in range(n):  # sub-env i is the single env seeded seed + i
        single, _ = RandomMapEnv(preset="TEST1").reset(seed=seed + i)
        np.testing.assert_array_equal(oa[i], single)
    actions = np.tile(np.array([0.2, 0.4], np.float32), (n, 1))
    for _ in range(5):
        np.testing.assert_array_equal(a.step(actions)[0], b.step(actions)[0])
    assert a.np_random_seed == tuple(seed + i for i in range(n))
    oc, _ = a.reset(seed=[seed] * n)  # a list gives each sub-env its seed
    assert all(np.array_equal(oc[i], oc[0]) for i in range(n))


def test_reset_mask_resets_only_the_masked_sub_envs() -> None:
    envs = RandomMapVectorEnv(num_envs=3, preset="TEST1")
    obs0, _ = envs.reset(seed=5)
    for _ in range(3):
        obs, *_ = envs.step(np.tile(np.array([0.2, 0.5], np.float32), (3, 1)))
    mask = np.array([False, True, False])
    obs1, info = envs.reset(seed=5, options={"reset_mask": mask})
    np.testing.assert_array_equal(obs1[1], obs0[1])  # seed 5 + 1 again
    np.testing.assert_array_equal(obs1[[0, 2]], obs[[0, 2]])  # untouched
    np.testing.assert_array_equal(info["_outcome"], mask)


def test_autoreset_follows_next_step_mode() -> None:
    envs = RandomMapVectorEnv(num_envs=2, preset="TEST1", max_episode_steps=3)
    envs.reset(seed=1)
    act = np.zeros((2, 2), np.float32)
    for _ in range(2):
        _, _, term, trunc, _ = envs.step(act)
        assert not (term | trunc).any()
    obs, rew, term, trunc, info = envs.step(act)
    assert trunc.all() and info["outcome"].tolist() == ["trap", "trap"]
    assert info["metrics"]["steps"].tolist() == [3, 3]
    obs, rew, term, trunc, info = envs.step(act)  # the reset step
    np.testing.assert_array_equal(rew, 0.0)
    assert not (term | trunc).any() and "clearance_m" not in info
    single, _ = RandomMapEnv(preset="TEST1", max_episode_steps=3).reset(seed=1)
    assert not np.array_equal(obs[0], single)  # a fresh map from the sub-env's own stream


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"num_envs": 0}, "num_envs must be an integer >= 1, got 0"),
        ({"num_envs": 2, "dynamics": "pybullet"}, "reduced drive model or the plant"),
        ({"num_envs": 2, "preset": "HARD"}, "unknown map preset 'HARD'"),
        ({"num_envs": 2, "goal_speed_mps": 0.05}, "goal by distance alone, got goal_speed"),
        ({"num_envs": 1, "goal_speed_mps": -1.0}, "goal_speed_mps must be a number of m/s > 0"),
    ],
)
def test_bad_constructor_arguments_name_the_argument(kwargs: dict[str, Any], match: str) -> None:
    with pytest.raises(Sim2RealValueError, match=match):
        RandomMapVectorEnv(**kwargs)


def test_bad_actions_seeds_and_masks_are_refused_in_one_sentence() -> None:
    envs = RandomMapVectorEnv(num_envs=2, preset="TEST1")
    with pytest.raises(Sim2RealValueError, match=r"before sub-env\(s\) \[0, 1\] were reset"):
        envs.step(np.zeros((2, 2)))
    envs.reset(seed=0)
    with pytest.raises(Sim2RealValueError, match=r"actions must be 2 rows .* got shape \(2,\)"):
        envs.step(np.zeros(2))
    with pytest.raises(Sim2RealValueError, match="with NaN or inf"):
        envs.step(np.array([[0.1, 0.0], [np.nan, 0.0]]))
    with pytest.raises(Sim2RealValueError, match="list of 2 seeds"):
        envs.reset(seed=[1, 2, 3])
    with pytest.raises(Sim2RealValueError, match="reset_mask"):
        envs.reset(options={"reset_mask": np.zeros(2, dtype=bool)})
    with pytest.raises(Sim2RealValueError, match="sequence of 2"):
        envs.set_drive_params([load_spec("turtlebot3_burger").drive])


def lidar_and_odometry_noise(env: gym.Env[Any, Any]) -> gym.Env[Any, Any]:
    """A stack of two observation randomizers on RandomMap-v0's Box(40)."""
    from randomizers import LidarNoise, ObservationNoise

    env = LidarNoise(env, std_m=0.02, dropout=0.1, index=[0, 36])
    return ObservationNoise(env, std=[0.01, 0.05], index=[38, 40])


def test_observation_randomizers_per_sub_env_equal_wrapped_single_envs() -> None:
    from randomizers import VectorObservationRandomizer, set_scale

    kw = {"preset": "TEST4", "max_episode_steps": 40}
    vec = VectorObservationRandomizer(
        RandomMapVectorEnv(num_envs=3, **kw), lidar_and_odometry_noise
    )
    sync = SyncVectorEnv([lambda: lidar_and_odometry_noise(RandomMapEnv(**kw)) for _ in range(3)])
    ov, iv = vec.reset(seed=11)
    os_, is_ = sync.reset(seed=11)
    np.testing.assert_array_equal(ov, os_)
    clean, _ = RandomMapVectorEnv(num_envs=3, **kw).reset(seed=11)
    assert not np.array_equal(ov, clean)  # the noise is there
    assert_infos_equal(iv["randomization"], is_["randomization"], "reset")
    rng = np.random.default_rng(4)
    resets = 0
    for t in range(100):
        actions = rng.uniform([0.0, -1.0], [0.21, 1.0], (3, 2)).astype(np.float32)
        rv, rs = vec.step(actions), sync.step(actions)
        np.testing.assert_array_equal(rv[0], rs[0], err_msg=f"step {t}")
        np.testing.assert_array_equal(rv[2] | rv[3], rs[2] | rs[3])
        assert_infos_equal(rv[4]["randomization"], rs[4]["randomization"], f"step {t}")
        resets += int((rv[2] | rv[3]).sum())
    assert resets >= 3  # autoresets happened (the stacks' streams continue across them)
    assert set_scale(vec, 0.5) == 2  # per sub-env stack: two randomizers
    assert [s.scale for s in vec.stacks] == [1.0, 1.0, 1.0]  # from the next reset on
    vec.reset()
    assert [s.scale for s in vec.stacks] == [0.5, 0.5, 0.5]


def test_vector_randomizer_refuses_non_observation_wrappers() -> None:
    from randomizers import ActionDelay, VectorObservationRandomizer
    from randomizers.errors import RandomizerTypeError

    with pytest.raises(RandomizerTypeError, match=r"observation randomizers only.*ActionDelay"):
        VectorObservationRandomizer(
            RandomMapVectorEnv(num_envs=2), lambda e: ActionDelay(e, delay_steps=1)
        )


@pytest.mark.parametrize(
    "kwargs",
    [
        {"scenario": "dynamic", "complexity": 1.0},
        {"scenario": "occluded", "complexity": 0.7},
        {"scenario": "dynamic", "pedestrians": "orca"},
    ],
)
def test_crowd_nav_vector_env_equals_single_envs(kwargs: dict[str, Any]) -> None:
    from sim2real.envs import CrowdNavEnv, CrowdNavVectorEnv

    kw = {**kwargs, "max_episode_steps": 50}
    vec = gym.make_vec(
        "sim2real/CrowdNav-v0", num_envs=3, vectorization_mode="vector_entry_point", **kw
    )
    assert isinstance(vec.unwrapped, CrowdNavVectorEnv)
    sync = SyncVectorEnv([lambda: CrowdNavEnv(**kw) for _ in range(3)])
    ov, iv = vec.reset(seed=21)
    os_, is_ = sync.reset(seed=21)
    for key in os_:
        np.testing.assert_array_equal(ov[key], os_[key], err_msg=key)
    assert_infos_equal(iv, is_, "reset")
    assert vec.observation_space.contains(ov)
    rng = np.random.default_rng(8)
    space = sync.single_action_space
    ends = 0
    for t in range(110):
        actions = rng.uniform(space.low, space.high, (3, 2)).astype(np.float32)
        rv, rs = vec.step(actions), sync.step(actions)
        for key in rs[0]:
            np.testing.assert_array_equal(rv[0][key], rs[0][key], err_msg=f"{key}, step {t}")
        np.testing.assert_allclose(rv[1], rs[1], rtol=1e-12, atol=1e-12, err_msg=f"step {t}")
        np.testing.assert_array_equal(rv[2], rs[2])
        np.testing.assert_array_equal(rv[3], rs[3])
        assert_infos_equal(rv[4], rs[4], f"step {t}")
        ends += int((rv[2] | rv[3]).sum())
    assert ends >= 4  # autoresets happened


def burger_distribution() -> Any:
    from robots.randomization import DriveDistribution

    spec = load_spec("turtlebot3_burger")
    return DriveDistribution.from_priors(spec.name, spec.geometry, spec.priors)


def test_each_episode_draws_its_robot_from_np_random_in_single_and_vector_envs() -> None:
    dist = burger_distribution()
    env = RandomMapEnv(preset="TEST1", drive_distribution=dist)
    env.reset(seed=4)
    first = env.get_drive_params()
    env.reset(seed=4)
    assert env.get_drive_params() == first  # same seed, same robot
    env.reset(seed=5)
    assert env.get_drive_params() != first
    assert first != load_spec("turtlebot3_burger").drive
    plain = RandomMapEnv(preset="TEST1")
    plain.reset(seed=5)
    assert env.layout is not None and plain.layout is not None  # the robot is drawn after
    np.testing.assert_array_equal(env.layout.cylinders, plain.layout.cylinders)  # the map
    # the vector env's sub-envs draw the single envs' robots, also at autoresets
    kw = {"preset": "TEST4", "max_episode_steps": 30, "drive_distribution": dist}
    vec, sync = make_pair(3, **kw)
    run_both(vec, sync, steps=70, seed=9, rng_seed=3)
    drawn = vec.unwrapped.get_drive_params()
    assert drawn == tuple(e.unwrapped.get_drive_params() for e in sync.envs)
    assert len(set(drawn)) == 3


def test_drive_distribution_of_another_robot_or_a_bad_spread_is_refused() -> None:
    from robots.randomization import DriveDistribution

    spec = load_spec("turtlebot2")
    other = DriveDistribution.from_priors(spec.name, spec.geometry, spec.priors)
    with pytest.raises(Sim2RealValueError, match="is for robot 'turtlebot2' but the env drives"):
        RandomMapEnv(drive_distribution=other)
    with pytest.raises(Sim2RealValueError, match="drive_spread must be a finite number >= 0"):
        RandomMapEnv(drive_distribution=burger_distribution(), drive_spread=-1.0)


@pytest.mark.slow
def test_a_vector_env_compiles_cold_in_a_process_that_ran_no_other_kernel(tmp_path: Any) -> None:
    """robots compiles its drive kernels on first use (robots._jit); in a fresh process with an
    empty numba cache whose first kernel call is a vector env's step, ours (which call robots'
    drive kernels) must still compile. It failed so on a clean clone (numba typing error)."""
    code = (
        "import gymnasium as gym, numpy as np, sim2real.envs\n"
        "env = gym.make_vec('sim2real/RandomMap-v0', num_envs=2, "
        "vectorization_mode='vector_entry_point')\n"
        "env.reset(seed=0)\n"
        "obs, reward, term, trunc, info = env.step(np.zeros((2, 2), dtype=np.float32))\n"
        "print(reward.shape, term.dtype)\n"
    )
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)}  # cold: nothing cached
    out = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
        env=env,
    )
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip() == "(2,) bool"


@pytest.mark.parametrize(
    ("beams", "yaw_scale"),
    [
        (np.linspace(-np.pi / 6, np.pi / 6, 640), 3.0),  # CrowdNav's lidar
        (2 * np.pi * np.arange(36) / 36, 3.0),  # RandomMap's, past +-pi
        (np.linspace(-np.pi, np.pi, 181), 200.0),  # a full scan, a wound-up yaw
        (np.array([0.3, -1.0, 2.0, 0.1]), 3.0),  # unsorted: every obstacle against every beam
    ],
)
def test_lidar_casting_by_beam_spans_equals_casting_every_ray(
    beams: np.ndarray, yaw_scale: float
) -> None:
    """The vector envs' lidar casts each obstacle only along the beams it can be seen under;
    the ranges must be cast_rays' (every ray against every obstacle) to the bit, also with the
    origin inside a circle, on a segment or in line with one."""
    from sim2real.envs._vecnav import Readings, sense
    from sim2real.envs.geometry import Scene2D, cast_rays

    rng = np.random.default_rng(5)
    n, nc, ns = 40, 12, 10
    cxy, cr = rng.uniform(-4, 4, (n, nc, 2)), rng.uniform(0.05, 0.6, (n, nc))
    sa, sb = rng.uniform(-5, 5, (n, ns, 2)), rng.uniform(-5, 5, (n, ns, 2))
    pose = np.column_stack([rng.uniform(-4, 4, (n, 2)), rng.uniform(-yaw_scale, yaw_scale, n)])
    pose[0, :2] = cxy[0, 0]  # inside a circle
    pose[1, :2] = 0.3 * sa[1, 0] + 0.7 * sb[1, 0]  # on a segment
    sa[2, 0], sb[2, 0] = pose[2, :2] + [1.0, 1.0], pose[2, :2] + [3.0, 3.0]  # in line
    sb[3, 1] = sa[3, 1] + [1e-9, 0.0]  # a tiny segment
    counts_c, counts_s = rng.integers(0, nc + 1, n), rng.integers(0, ns + 1, n)
    ranges = np.zeros((n, beams.size))
    sense(
        np.ones(n, dtype=np.bool_),
        pose,
        np.zeros(2),
        beams,
        0.0,
        6.0,
        cxy,
        cr,
        counts_c,
        sa,
        sb,
        counts_s,
        np.zeros((n, 2)),
        0.2,
        Readings(ranges=ranges, goal_polar=np.zeros((n, 2)), clearance=np.zeros(n)),
    )
    for i in range(n):
        c, s = counts_c[i], counts_s[i]
        scene = Scene2D(
            circles_xy=cxy[i, :c], circles_r=cr[i, :c], seg_a=sa[i, :s], seg_b=sb[i, :s]
        )
        expected = cast_rays(scene, pose[i, :2], beams + pose[i, 2], 6.0)
        np.testing.assert_array_equal(ranges[i], expected, err_msg=f"env {i}")
    assert (ranges < 6.0).mean() > 0.2  # the beams do hit things


def test_crowd_nav_sub_env_crowds_show_the_state_the_vector_env_steps() -> None:
    """envs.envs[i].crowd holds views of the batched pedestrian rows: the same positions,
    velocities, goals and clock as a single env's crowd, also after a reset with more
    pedestrians grew the rows."""
    from sim2real.envs import CrowdNavEnv, CrowdNavVectorEnv

    kw: dict[str, Any] = {"scenario": "dynamic", "complexity": 1.0, "max_episode_steps": 400}
    vec = CrowdNavVectorEnv(num_envs=2, **kw)
    singles = [CrowdNavEnv(**kw) for _ in range(2)]
    actions = np.array([[0.0, 0.0], [0.0, 0.0]], dtype=np.float32)

    def check(where: str) -> None:
        for sub, single in zip(vec.envs, singles, strict=True):
            a, b = sub.crowd, single.crowd  # type: ignore[attr-defined]
            assert a is not None and b is not None
            for name in ("position_m", "velocity_mps", "goals"):
                np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=where)
            assert a.time_s == b.time_s

    for opts in (None, {"num_pedestrians": 45}):
        vec.reset(seed=[3, 4], options=opts)
        for i, single in enumerate(singles):
            single.reset(seed=3 + i, options=opts)
        for t in range(25):
            vec.step(actions)
            for single in singles:
                single.step(actions[0])
            check(f"{opts}, step {t}")
    assert len(vec.envs[0].crowd) == 45  # type: ignore[attr-defined]
    assert vec._crowds.position_m.shape[1] >= 45  # the rows grew
