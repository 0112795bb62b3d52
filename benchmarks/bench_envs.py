"""Speed of the reference envs and of their sensors, with baselines measured in the same run.

Run: ``.venv/bin/python benchmarks/bench_envs.py`` (one core: BLAS threads are pinned to 1).

Targets (issue 7): RandomMap-v0 TRAIN, control_dt 0.1 s, dynamics="reduced" >= 1,000 env
steps/s; CrowdNav-v0 with 64 x 48 depth, lidar and 20 pedestrians, dynamics="reduced" >= 300
env steps/s. Baselines: pybullet's ``rayTestBatch`` against the same cylinders for the lidar,
pybullet's TinyRenderer for the depth image, and the dynamics="pybullet" back-end.
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import math
import time
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np
import pybullet as p

import sim2real.envs  # noqa: F401  (registers the ids)
from sim2real.envs._world import PybulletWorld, render_pybullet_depth
from sim2real.envs.geometry import cast_rays, cast_rays_numpy
from sim2real.envs.maps import PRESETS, generate_map


def per_call_s(fn: Callable[[], object], *, min_time_s: float = 1.0) -> float:
    """Mean wall time of one call, s (after one warm-up call)."""
    fn()
    n, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < min_time_s:
        fn()
        n += 1
    return (time.perf_counter() - t0) / n


def env_steps_per_s(
    env_id: str, *, seconds: float = 3.0, options: dict[str, Any] | None = None, **kw: Any
) -> tuple[float, float]:
    """Env steps per second of wall time and of process CPU time (random actions, resets).

    The machine may be shared: the CPU-time rate is what one core delivers to this process.
    """
    env: Any = gym.make(env_id, **kw)
    rng = np.random.default_rng(0)
    env.reset(seed=0, options=options)
    low, high = env.action_space.low, env.action_space.high
    env.step(rng.uniform(low, high).astype(np.float32))  # warm-up (numba cache load)
    n, t0, c0 = 0, time.perf_counter(), time.process_time()
    while time.perf_counter() - t0 < seconds:
        _, _, term, trunc, _ = env.step(rng.uniform(low, high).astype(np.float32))
        n += 1
        if term or trunc:
            env.reset(options=options)
    rate = n / (time.perf_counter() - t0), n / (time.process_time() - c0)
    env.close()
    return rate


def bench_lidar() -> None:
    layout = generate_map(PRESETS["TRAIN"], np.random.default_rng(0))
    angles = 2 * math.pi * np.arange(36) / 36
    origin = np.array([0.5, 0.2])
    world = PybulletWorld()
    world.set_static(
        cylinders=layout.cylinders, cylinder_height_m=0.5, boxes=layout.walls, box_height_m=0.5
    )
    starts = [[origin[0], origin[1], 0.17]] * 36
    ends = [[origin[0] + 3.5 * math.cos(a), origin[1] + 3.5 * math.sin(a), 0.17] for a in angles]
    t_pb = per_call_s(lambda: p.rayTestBatch(starts, ends, physicsClientId=world.client))
    world.close()
    t_np = per_call_s(lambda: cast_rays_numpy(layout.scene, origin, angles, 3.5))
    t_nb = per_call_s(lambda: cast_rays(layout.scene, origin, angles, 3.5))
    n_obj = len(layout.cylinders) + len(layout.walls)
    print(f"lidar, 36 beams vs a TRAIN map ({n_obj} obstacles):")
    print(f"  pybullet rayTestBatch   {1e6 * t_pb:8.1f} us/scan  ({1e6 * t_pb / 36:.2f} us/ray)")
    print(f"  2-D caster, numpy       {1e6 * t_np:8.1f} us/scan  ({t_pb / t_np:.1f}x pybullet)")
    print(f"  2-D caster, numba       {1e6 * t_nb:8.1f} us/scan  ({t_pb / t_nb:.1f}x pybullet)")


def bench_depth() -> None:
    env: Any = gym.make("sim2real/CrowdNav-v0").unwrapped
    env.reset(seed=0, options={"scenario": "dynamic", "complexity": 1.0})
    scene, cam = env._depth_scene, env.camera
    x, y, yaw = env._backend.pose
    world = PybulletWorld()
    world.set_static(
        cylinders=scene.cylinders[:, :3],
        cylinder_height_m=scene.cylinders[:, 3],
        boxes=scene.boxes[:, :5],
        box_height_m=scene.boxes[:, 5],
    )
    view = cam.update_view(x, y, yaw)
    kw = dict(width=64, height=48, hfov_deg=cam.hfov_deg, near_m=cam.near_m, far_m=cam.far_m)
    t_pb = per_call_s(lambda: render_pybullet_depth(world, view, **kw))  # type: ignore[arg-type]
    t_nb = per_call_s(lambda: cam.render(scene, x, y, yaw))
    world.close()
    env.close()
    n = len(scene.cylinders) + len(scene.boxes)
    print(f"depth 64x48, CrowdNav dynamic c=1 ({n} bodies):")
    print(f"  pybullet TinyRenderer   {1e3 * t_pb:8.3f} ms/frame")
    print(f"  numba 2.5-D ray caster  {1e3 * t_nb:8.3f} ms/frame  ({t_pb / t_nb:.1f}x pybullet)")


def bench_envs() -> None:
    rm_red = env_steps_per_s("sim2real/RandomMap-v0", preset="TRAIN", dynamics="reduced")
    rm_pb = env_steps_per_s("sim2real/RandomMap-v0", preset="TRAIN", dynamics="pybullet")
    opts = {"scenario": "dynamic", "complexity": 1.0}  # 20 pedestrians + 10 obstacles
    cn_red = env_steps_per_s("sim2real/CrowdNav-v0", options=opts, dynamics="reduced")
    cn_pb = env_steps_per_s("sim2real/CrowdNav-v0", options=opts, dynamics="pybullet")
    ok1 = "PASS" if rm_red[0] >= 1000 else "FAIL"
    ok2 = "PASS" if cn_red[0] >= 300 else "FAIL"
    print("env steps/s (random actions, resets included; wall clock / per CPU-second):")
    print(f"  RandomMap-v0 TRAIN  reduced  {rm_red[0]:7.0f} / {rm_red[1]:7.0f}   >= 1000: {ok1}")
    print(
        f"  RandomMap-v0 TRAIN  pybullet {rm_pb[0]:7.0f} / {rm_pb[1]:7.0f}   "
        f"reduced is {rm_red[1] / rm_pb[1]:.1f}x"
    )
    print(f"  CrowdNav-v0 20 peds reduced  {cn_red[0]:7.0f} / {cn_red[1]:7.0f}   >= 300: {ok2}")
    print(
        f"  CrowdNav-v0 20 peds pybullet {cn_pb[0]:7.0f} / {cn_pb[1]:7.0f}   "
        f"reduced is {cn_red[1] / cn_pb[1]:.1f}x"
    )


if __name__ == "__main__":
    bench_lidar()
    bench_depth()
    bench_envs()
