"""SARL*'s one-step look-ahead (``policy: sarl-lookahead``): the compiled prediction against the
torch one, per call and in DQN training steps per second.

Run from the repository root (needs the [train] extra)::

    .venv/bin/python benchmarks/bench_lookahead.py                 # ~6 min on 2 cores
    .venv/bin/python benchmarks/bench_lookahead.py --quick         # ~2 min

Two parts, each alternating its contenders in one process (``_timing.alternate``), so that the
machine's load, which varies on a shared machine, weighs on all of them alike; the ratios are
per repeat (min / median / max), wall time and CPU time both printed:

- ``predict``: :meth:`RaceLookahead.predict` on batches of 1 (acting) and 32 (a DQN update's
  replay batch) of real curve-race observations: the torch path ``predict_reference`` (the
  ``"point"`` lidar, the ``"command"`` motion), the compiled kernel with the same models (the
  same numbers: the tests check them to float precision), with the ``"recast"`` lidar and
  with the ``"recast"`` lidar and the ``"drive"`` motion (the model trained: the env's drive
  model run over each command's step), the last once with its store of driven motions emptied
  before every call (``drive, cold``: every observed velocity new) and once kept (a repeated
  batch: every velocity known);
- ``train``: DQN steps per second of ``examples/race_sarl_lookahead.yaml`` (its network, batch
  and update rate; ``learning_starts`` 500, so that most of the steps update) with the old path
  (``predict_reference`` and SB3's ``set_training_mode``) and the new one (kernel with the
  ``"recast"`` lidar and the ``"drive"`` motion, the mode switch skipped when unchanged), and
  the new one with its store of driven motions emptied before every prediction (``cold``): what
  keeping the motions of each observed velocity saves in training.

Target: the look-ahead's training run (120,000 steps) within the experiment's 60 minutes on 2
shared cores, i.e. >= 40 steps/s with the evaluation's time to spare.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import torch
import yaml
from _timing import QUICK, Stats, alternate, machine, paired_ratios
from stable_baselines3.dqn.policies import DQNPolicy

import sim2real.envs  # noqa: F401  (registers the envs)
from sim2real.training import _sb3
from sim2real.training._lookahead import LookaheadDQNPolicy, RaceLookahead, race_lookahead
from sim2real.training.config import config_from_dict
from sim2real.training.environment import DiscreteActions
from sim2real.training.train import build_env

REPO = Path(__file__).resolve().parents[1]
CONFIG = REPO / "examples" / "race_sarl_lookahead.yaml"


def _observations(n: int) -> torch.Tensor:
    """``n`` observations of a curve race with 4 opponents, random commands (seed 0)."""
    env = gym.make("sim2real/Race-v0", track="curve", num_opponents=4, control_dt=0.25)
    rng = np.random.default_rng(0)
    obs, _ = env.reset(seed=0)
    rows = []
    while len(rows) < n:
        obs, _, term, trunc, _ = env.step(
            np.array([rng.uniform(0.0, 0.22), rng.uniform(-1.0, 1.0)], np.float32)
        )
        rows.append(obs)
        if term or trunc:
            obs, _ = env.reset(seed=len(rows))
    return torch.as_tensor(np.array(rows))


def _ratio_line(name: str, old: Stats, new: Stats) -> str:
    wall = paired_ratios(old, new)
    cpu = paired_ratios(old.cpu(), new.cpu())
    return (
        f"  {name}: old/new {wall[0]:.2f}/{wall[1]:.2f}/{wall[2]:.2f} wall, "
        f"{cpu[0]:.2f}/{cpu[1]:.2f}/{cpu[2]:.2f} CPU (min/median/max)"
    )


def bench_predict(repeats: int, calls: int) -> None:
    doc = yaml.safe_load(CONFIG.read_text("utf-8"))
    env = gym.make("sim2real/Race-v0", track="curve", num_opponents=4, control_dt=0.25)
    drive = race_lookahead(env, **doc["discrete_actions"])
    recast = replace(drive, motion_model="command")
    point = replace(recast, lidar_model="point")
    obs = _observations(64)
    print(f"predict: {len(recast.v_mps)} commands, {calls} calls a repeat, {repeats} repeats")
    for batch in (1, 32):
        x = obs[:batch]

        def loop(f: Callable[[torch.Tensor], torch.Tensor], x: torch.Tensor = x) -> None:
            for _ in range(calls):
                f(x)

        stats = alternate(
            {
                "torch (point)": lambda: loop(point.predict_reference),
                "kernel (point)": lambda: loop(point.predict),
                "kernel (recast)": lambda: loop(recast.predict),
                "kernel (drive)": lambda: loop(drive.predict),
                "kernel (drive, cold)": lambda: loop(_cold(drive)),
            },
            repeats,
        )
        for name, s in stats.items():
            print(
                f"  batch {batch:2d} {name:20s} {s.median / calls * 1e6:8.1f} us a call "
                f"(CPU {statistics.median(s.cpu_s) / calls * 1e6:8.1f} us)"
            )
        print(
            _ratio_line(
                f"batch {batch} torch / kernel (point)",
                stats["torch (point)"],
                stats["kernel (point)"],
            )
        )
        print(
            _ratio_line(
                f"batch {batch} torch / kernel (recast)",
                stats["torch (point)"],
                stats["kernel (recast)"],
            )
        )
        print(
            _ratio_line(
                f"batch {batch} kernel command / drive motion (recast)",
                stats["kernel (recast)"],
                stats["kernel (drive)"],
            )
        )
        print(
            _ratio_line(
                f"batch {batch} drive motion cold / kept",
                stats["kernel (drive, cold)"],
                stats["kernel (drive)"],
            )
        )


def _cold(model: RaceLookahead) -> Callable[[torch.Tensor], torch.Tensor]:
    """``model.predict`` with its store of driven motions emptied before each call."""

    def predict(x: torch.Tensor) -> torch.Tensor:
        model._motion_store.clear()
        return model.predict(x)

    return predict


def _train_once(steps: int, old: bool, cold: bool = False) -> None:
    doc = yaml.safe_load(CONFIG.read_text("utf-8"))
    doc["hyperparameters"]["learning_starts"] = 500
    doc["checkpoint_every"] = 0
    doc["out"] = tempfile.mkdtemp(prefix="bench_lookahead_")
    cfg = config_from_dict(doc, timesteps=steps)
    probe = DiscreteActions(
        build_env(cfg.env_id, cfg.env_kwargs, randomizers=None, where="bench"),
        **dict(cfg.discrete_actions or {}),
    )
    saved: dict[str, Any] = {}
    if old:
        saved = {
            "predict": RaceLookahead.predict,
            "set_training_mode": LookaheadDQNPolicy.set_training_mode,
        }
        RaceLookahead.predict = RaceLookahead.predict_reference  # type: ignore[method-assign]
        LookaheadDQNPolicy.set_training_mode = DQNPolicy.set_training_mode  # type: ignore[method-assign]
        # the torch path knows the point lidar and the command motion only
        real = race_lookahead
        _sb3.race_lookahead = lambda *a, **k: replace(  # type: ignore[assignment]
            real(*a, **k), lidar_model="point", motion_model="command"
        )
    kept = RaceLookahead.motions
    if cold:
        RaceLookahead.motions = lambda self, flat: (  # type: ignore[method-assign]
            self._motion_store.clear(),
            kept(self, flat),
        )[1]
    try:
        _sb3.learn(cfg, probe)
    finally:
        RaceLookahead.motions = kept  # type: ignore[method-assign]
        if old:
            RaceLookahead.predict = saved["predict"]  # type: ignore[method-assign]
            LookaheadDQNPolicy.set_training_mode = saved["set_training_mode"]  # type: ignore[method-assign]
            _sb3.race_lookahead = race_lookahead
        probe.close()


def bench_train(repeats: int, steps: int) -> None:
    print(f"train: {steps} DQN steps a repeat (learning_starts 500), {repeats} repeats")
    for old in (True, False):  # compile and load caches outside the timed repeats
        _train_once(100, old)
    stats = alternate(
        {
            "old": lambda: _train_once(steps, True),
            "cold": lambda: _train_once(steps, False, cold=True),
            "new": lambda: _train_once(steps, False),
        },
        repeats,
        warmup=False,
    )
    for name, s in stats.items():
        cpu = Stats(times_s=s.cpu_s, cpu_s=s.cpu_s)
        print(
            f"  {name}: {steps / s.median:6.1f} steps/s wall (min/median/max "
            f"{steps / s.max:.1f}/{steps / s.median:.1f}/{steps / s.min:.1f}), "
            f"{steps / cpu.median:6.1f} steps per CPU second"
        )
    print(_ratio_line("old / new time a step", stats["old"], stats["new"]))
    print(_ratio_line("cold / kept driven motions, time a step", stats["cold"], stats["new"]))


def main() -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repeats and steps")
    parser.add_argument("--only", choices=("predict", "train"), help="run one part")
    args = parser.parse_args()
    quick = args.quick or QUICK
    torch.set_num_threads(1)  # as sim2real train does
    print(machine())
    if args.only in (None, "predict"):
        bench_predict(3 if quick else 5, 50 if quick else 200)
    if args.only in (None, "train"):
        bench_train(1 if quick else 2, 1500 if quick else 3000)


if __name__ == "__main__":
    main()
