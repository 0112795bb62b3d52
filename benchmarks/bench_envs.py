"""Speed of the reference envs, their sensors and the native vector envs, with baselines
measured in the same run (contenders alternated, same repeat count, min/median/max).

Run: ``.venv/bin/python benchmarks/bench_envs.py [--quick] [--only vector]`` (one core: BLAS
threads pinned; ``--only vector`` times just the two native vector envs, about a minute idle).

Targets
-------
- RandomMap-v0 TRAIN, control_dt 0.1 s, dynamics="reduced" >= 1,000 env steps/s;
  CrowdNav-v0 with 64 x 48 depth, lidar and 20 pedestrians, reduced >= 300 env steps/s.
- the native vector RandomMap-v0 (``vectorization_mode="vector_entry_point"``), 64
  envs, >= 50,000 env steps/s; the native vector CrowdNav-v0 >= 5,000 env steps/s.

Every env rate is printed per second of wall clock and per second of this process's CPU time.
The machine is shared by other jobs: the wall clock then mostly measures the queue, the CPU
time what one core delivers, so the targets are judged on the CPU-time rate (both printed and
recorded). Random actions crash often, so the rates include many resets (map draws).
Baselines: pybullet's ``rayTestBatch`` for the lidar, pybullet's TinyRenderer for the depth
image, the dynamics="pybullet" back-end, one env, and gymnasium's ``SyncVectorEnv``.
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import math
import statistics
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np
import pybullet as p
from _timing import (
    QUICK,
    Stats,
    alternate,
    bench_arguments,
    fmt_ratio,
    machine,
    paired_ratios,
    record,
)

import sim2real.envs  # noqa: F401  (registers the ids)
from sim2real.envs._world import PybulletWorld, render_pybullet_depth
from sim2real.envs.geometry import cast_rays, cast_rays_numpy
from sim2real.envs.maps import PRESETS, generate_map

BENCH = "envs"
CROWD_OPTIONS = {"scenario": "dynamic", "complexity": 1.0}  # 20 pedestrians + 10 obstacles


def repeat(fn: Callable[[], object], calls: int) -> Callable[[], None]:
    """``fn`` called ``calls`` times (one timed repeat)."""

    def run() -> None:
        for _ in range(calls):
            fn()

    return run


def _print_times(t: dict[str, Stats], labels: dict[str, str], per_call: float, unit: str) -> None:
    """A line per contender (its time per call, ``per_call`` x the repeat's), each after the
    first followed by the first's time over its own."""
    first = next(iter(labels))
    for key, label in labels.items():
        print(f"  {label:<24}{t[key].fmt(per_call, unit)}")
        if key != first:
            print(f"    {first}/{key} time".ljust(26) + fmt_ratio(t[first], t[key]))


def bench_lidar(repeats: int) -> None:
    layout = generate_map(PRESETS["TRAIN"], np.random.default_rng(0))
    angles = 2 * math.pi * np.arange(36) / 36
    origin = np.array([0.5, 0.2])
    world = PybulletWorld()
    world.set_static(
        cylinders=layout.cylinders, cylinder_height_m=0.5, boxes=layout.walls, box_height_m=0.5
    )
    starts = [[origin[0], origin[1], 0.17]] * 36
    ends = [[origin[0] + 3.5 * math.cos(a), origin[1] + 3.5 * math.sin(a), 0.17] for a in angles]
    calls = 200
    t = alternate(
        {
            "pybullet": repeat(
                lambda: p.rayTestBatch(starts, ends, physicsClientId=world.client), calls
            ),
            "numpy": repeat(lambda: cast_rays_numpy(layout.scene, origin, angles, 3.5), calls),
            "numba": repeat(lambda: cast_rays(layout.scene, origin, angles, 3.5), calls),
        },
        repeats,
    )
    world.close()
    n_obj = len(layout.cylinders) + len(layout.walls)
    us = 1e6 / calls
    print(f"lidar, 36 beams vs a TRAIN map ({n_obj} obstacles), per scan:")
    labels = {"pybullet": "pybullet rayTestBatch", "numpy": "2-D caster, numpy"}
    _print_times(t, labels | {"numba": "2-D caster, numba"}, us, "us")


def bench_depth(repeats: int) -> None:
    env: Any = gym.make("sim2real/CrowdNav-v0").unwrapped
    env.reset(seed=0, options=CROWD_OPTIONS)
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
    calls = 20
    t = alternate(
        {
            "pybullet": repeat(lambda: render_pybullet_depth(world, view, **kw), calls),  # type: ignore[arg-type]
            "numba": repeat(lambda: cam.render(scene, x, y, yaw), calls),
        },
        repeats,
    )
    world.close()
    env.close()
    n = len(scene.cylinders) + len(scene.boxes)
    ms = 1e3 / calls
    print(f"depth 64x48, CrowdNav dynamic c=1 ({n} bodies), per frame:")
    _print_times(
        t, {"pybullet": "pybullet TinyRenderer", "numba": "numba 2.5-D ray caster"}, ms, "ms"
    )


@dataclass
class Runner:
    """Steps an env (single or vector) for ``env_steps`` env steps per call; sums CPU time."""

    env: Any
    batch: int  # sub-envs per step (1 for a single env)
    env_steps: int
    options: dict[str, Any] | None
    actions: list[np.ndarray]
    cpu_s: list[float]

    @classmethod
    def make(
        cls, env: Any, batch: int, env_steps: int, options: dict[str, Any] | None = None
    ) -> Runner:
        """Reset ``env`` (seed 0) and draw 64 random actions to cycle through."""
        env.reset(seed=0, options=options)
        space = env.action_space
        rng = np.random.default_rng(1)
        actions = [
            (space.low + (space.high - space.low) * rng.random(space.shape)).astype(space.dtype)
            for _ in range(64)
        ]
        return cls(
            env=env, batch=batch, env_steps=env_steps, options=options, actions=actions, cpu_s=[]
        )

    def __call__(self) -> None:
        c0 = time.process_time()
        steps = self.env_steps // self.batch
        env, acts = self.env, self.actions
        if self.batch == 1:
            for k in range(steps):
                _, _, term, trunc, _ = env.step(acts[k % 64])
                if term or trunc:
                    env.reset(options=self.options)
        else:  # vector envs autoreset
            for k in range(steps):
                env.step(acts[k % 64])
        self.cpu_s.append(time.process_time() - c0)

    def cpu_rates(self) -> tuple[float, float, float]:
        """(min, median, max) env steps per CPU-second over the timed repeats."""
        rates = [self.env_steps / c for c in self.cpu_s[1:]]  # [0] is the warm-up
        return min(rates), statistics.median(rates), max(rates)


def _rate_line(name: str, stats: Stats, runner: Runner) -> str:
    lo, med, hi = stats.rate(runner.env_steps)
    c_lo, c_med, c_hi = runner.cpu_rates()
    return (
        f"  {name:<34} wall {lo:8.0f}/{med:8.0f}/{hi:8.0f}   "
        f"CPU {c_lo:8.0f}/{c_med:8.0f}/{c_hi:8.0f} env steps/s (min/median/max)"
    )


def _verdict(runner: Runner, target: float) -> tuple[str, bool]:
    med = runner.cpu_rates()[1]
    return f">= {target:,.0f}: {'PASS' if med >= target else 'FAIL'} (CPU-time rate)", med >= target


def _record_rate(figure: str, stats: Stats, runner: Runner, target: float) -> None:
    wall = stats.rate(runner.env_steps)[1]
    cpu = runner.cpu_rates()[1]
    _, met = _verdict(runner, target)
    record(
        BENCH,
        figure,
        f"{cpu:,.0f} env steps/s per CPU-second (wall {wall:,.0f}; shared machine, "
        f"load {os.getloadavg()[0]:.1f})",
        f">= {target:,.0f} per CPU-second",
        met,
    )


def bench_vector(
    env_id: str, n: int, steps: int, kw: dict[str, Any], target: float, repeats: int
) -> None:
    """One env, gymnasium's SyncVectorEnv and the native vector env, same env steps."""
    name = env_id.split("/")[1]
    runners = {
        "one env": Runner.make(gym.make(env_id, **kw), 1, steps),
        f"SyncVectorEnv, {n} envs": Runner.make(
            gym.make_vec(env_id, num_envs=n, vectorization_mode="sync", **kw), n, steps
        ),
        f"native vector env, {n} envs": Runner.make(
            gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point", **kw),
            n,
            steps,
        ),
    }
    t = alternate(runners, repeats)  # type: ignore[arg-type]
    one, sync, native = list(runners)
    print(f"{name} {kw}, random actions ({steps} env steps per repeat):")
    for label in runners:
        print(_rate_line(label, t[label], runners[label]))
    print(f"    native vector, {n} envs {_verdict(runners[native], target)[0]}")
    print(f"    speed-up vs one env (time ratio)        {fmt_ratio(t[one], t[native])}")
    print(f"    speed-up vs SyncVectorEnv (time ratio)  {fmt_ratio(t[sync], t[native])}")
    _record_rate(f"{name} native vector env, {n} envs", t[native], runners[native], target)
    ratio = paired_ratios(t[one], t[native])[1]
    record(
        BENCH, f"{name} native vector ({n} envs) / one env, time ratio", f"{ratio:.1f}x", "-", None
    )
    for r in runners.values():
        r.env.close()


def bench_random_map(repeats: int, scale: float) -> None:
    n = 64
    steps = max(n, int(n * 160 * scale))
    bench_vector(
        "sim2real/RandomMap-v0",
        n,
        steps,
        {"preset": "TRAIN", "dynamics": "reduced"},
        50_000,
        repeats,
    )


def bench_crowd_nav(repeats: int, scale: float) -> None:
    n = 16
    steps = max(n, int(n * 40 * scale))
    bench_vector("sim2real/CrowdNav-v0", n, steps, dict(CROWD_OPTIONS), 5_000, repeats)


def bench_backends(repeats: int, scale: float) -> None:
    """Reduced vs pybullet back-end, one env each (RandomMap-v0 and CrowdNav-v0)."""
    steps = max(20, int(200 * scale))
    for env_id, options, target in (
        ("sim2real/RandomMap-v0", None, 1000),
        ("sim2real/CrowdNav-v0", CROWD_OPTIONS, 300),
    ):
        runners = {
            dyn: Runner.make(gym.make(env_id, dynamics=dyn), 1, steps, options)
            for dyn in ("reduced", "pybullet")
        }
        t = alternate(runners, repeats)  # type: ignore[arg-type]
        label = env_id.split("/")[1] + (" 20 pedestrians" if options else " TRAIN")
        print(f"{label}, one env ({steps} steps per repeat):")
        for dyn, runner in runners.items():
            print(_rate_line(dyn, t[dyn], runner))
        print(f"    reduced speed-up (time ratio)  {fmt_ratio(t['pybullet'], t['reduced'])}")
        if target is not None:
            print(f"    reduced {_verdict(runners['reduced'], target)[0]}")
            _record_rate(
                f"{label.split()[0]} one env (reduced)", t["reduced"], runners["reduced"], target
            )
        for r in runners.values():
            r.env.close()


RUNS: dict[str, Callable[[int, float], None]] = {
    "lidar": lambda repeats, _scale: bench_lidar(repeats),
    "depth": lambda repeats, _scale: bench_depth(repeats),
    "random_map": bench_random_map,
    "crowd_nav": bench_crowd_nav,
    "backends": bench_backends,
}
#: --only choices: each part alone, and "vector" for the two native vector envs
PARTS: dict[str, tuple[str, ...]] = {
    **{k: (k,) for k in RUNS},
    "vector": ("random_map", "crowd_nav"),
}


def main() -> None:
    only = "run only this part (repeatable), e.g. --only vector (the vector-env targets)"
    parser = bench_arguments(__doc__, fewer="steps", parts=sorted(PARTS), only_help=only)
    args = parser.parse_args()
    quick = args.quick or QUICK
    scale = 0.1 if quick else 1.0
    repeats = 3 if quick else 7
    print(f"machine: {machine()}; load average {os.getloadavg()[0]:.2f}")
    chosen = {part for name in (args.only or sorted(PARTS)) for part in PARTS[name]}
    for part in ("lidar", "depth", "random_map", "crowd_nav", "backends"):
        if part in chosen:
            RUNS[part](repeats, scale)
    print(f"load average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
