"""Train SAC or PPO (stable-baselines3) on sim2real/RandomMap-v0 with a randomizer stack.

Needs the ``[train]`` extra (stable-baselines3 and torch; on CPU ``pip install torch==2.13.0``
finds a local wheel here)::

    .venv/bin/pip install -e '.[train]'
    .venv/bin/python examples/train_sb3.py --algo sac --steps 200000 \\
        --randomizers examples/randommap_randomizers.yaml --out runs/sac_randommap

The training env is ``RandomMap-v0`` (preset ``--preset``, default TRAIN) wrapped in the
randomizers of the YAML file (``randomizers.from_config``); the evaluation env uses the
``--eval-preset`` map without randomizers, every ``--eval-every`` steps, and the best model is
saved to ``OUT/best_model.zip``. A rich progress bar shows the steps. The paper (001) trained TD3/SAC with 2 x 256 MLPs and a learning rate of 3e-4; those
are the defaults here.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import gymnasium as gym

import sim2real.envs  # noqa: F401  (registers the env ids)


def _need(module: str) -> Any:
    try:
        return __import__(module, fromlist=["_"])
    except ImportError:
        sys.exit(
            f"train_sb3.py: error: '{module}' is not installed; install the training extra with "
            "`.venv/bin/pip install -e '.[train]'` (CPU torch: `pip install torch==2.13.0`)"
        )


def make_env(
    preset: str, randomizer_config: str | None, seed: int, max_episode_steps: int = 1000
) -> gym.Env[Any, Any]:
    """RandomMap-v0 with the randomizer stack of ``randomizer_config`` (None = plain)."""
    env: gym.Env[Any, Any] = gym.make(
        "sim2real/RandomMap-v0", preset=preset, max_episode_steps=max_episode_steps
    )
    if randomizer_config is not None:
        try:
            import randomizers
        except ImportError:
            sys.exit("train_sb3.py: error: the 'randomizers' package is missing from this install")
        env = randomizers.from_config(env, randomizer_config)
    env.reset(seed=seed)
    return env


def _rich_progress(base: type, total: int) -> Any:
    """An SB3 callback that draws a rich progress bar (rich is a core dependency; no tqdm)."""
    from rich.progress import BarColumn, Progress, TimeRemainingColumn

    class RichProgress(base):  # type: ignore[misc, valid-type]
        def _on_training_start(self) -> None:
            self._bar = Progress(
                "[progress.description]{task.description}",
                BarColumn(),
                "{task.completed}/{task.total} steps",
                TimeRemainingColumn(),
            )
            self._bar.start()
            self._task = self._bar.add_task("training", total=total)

        def _on_step(self) -> bool:
            self._bar.update(self._task, completed=self.num_timesteps)
            return True

        def _on_training_end(self) -> None:
            self._bar.stop()

    return RichProgress()


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--algo", choices=("sac", "ppo"), default="sac")
    ap.add_argument("--steps", type=int, default=200_000, help="training env steps")
    ap.add_argument("--preset", default="TRAIN", help="training map preset")
    ap.add_argument("--eval-preset", default="TEST2", help="evaluation map preset")
    ap.add_argument("--eval-every", type=int, default=10_000, help="steps between evaluations")
    ap.add_argument("--eval-episodes", type=int, default=5)
    ap.add_argument(
        "--randomizers", metavar="YAML", help="randomizer stack (randomizers.from_config)"
    )
    ap.add_argument("--max-episode-steps", type=int, default=1000, help="steps before a trap")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=Path("runs/randommap"), help="output folder")
    ap.add_argument("--no-progress", action="store_true", help="no progress bar")
    return ap.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    torch = _need("torch")
    torch.set_num_threads(1)  # 2 x 256 MLPs: threads only add overhead
    sb3 = _need("stable_baselines3")
    callbacks = _need("stable_baselines3.common.callbacks")
    monitor = _need("stable_baselines3.common.monitor")
    args.out.mkdir(parents=True, exist_ok=True)
    steps = args.max_episode_steps
    train_env = monitor.Monitor(make_env(args.preset, args.randomizers, args.seed, steps))
    eval_env = monitor.Monitor(make_env(args.eval_preset, None, args.seed + 10_000, steps))
    policy_kwargs = {"net_arch": [256, 256]}
    if args.algo == "sac":
        model = sb3.SAC(
            "MlpPolicy",
            train_env,
            learning_rate=3e-4,
            policy_kwargs=policy_kwargs,
            learning_starts=min(1000, args.steps // 2),
            seed=args.seed,
            verbose=0,
        )
    else:
        model = sb3.PPO(
            "MlpPolicy",
            train_env,
            learning_rate=3e-4,
            policy_kwargs=policy_kwargs,
            n_steps=min(2048, max(64, args.steps // 4)),
            batch_size=64,
            seed=args.seed,
            verbose=0,
        )
    evaluator = callbacks.EvalCallback(
        eval_env,
        n_eval_episodes=args.eval_episodes,
        eval_freq=max(1, args.eval_every),
        best_model_save_path=str(args.out),
        log_path=str(args.out),
        deterministic=True,
        verbose=1,
    )
    cb: list[Any] = [evaluator]
    if not args.no_progress:
        cb.append(_rich_progress(callbacks.BaseCallback, args.steps))
    model.learn(total_timesteps=args.steps, callback=cb)
    model.save(str(args.out / f"{args.algo}_final"))
    print(
        f"saved {args.out / (args.algo + '_final.zip')}; best eval reward "
        f"{evaluator.best_mean_reward:.2f}"
    )
    train_env.close()
    eval_env.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
