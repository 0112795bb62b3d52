"""`sim2real train` with stable-baselines3 and `envs eval --policy` on its model (needs [train]).

Small budgets (a few hundred steps, short episodes) keep these fast; they check the outputs,
the model's metadata, determinism of the seed, and the bad-input paths, not learning quality.
"""

from __future__ import annotations

import json
import zipfile
from pathlib import Path

import pytest
import yaml

from sim2real.cli import main

pytestmark = pytest.mark.train

ROOT = Path(__file__).resolve().parents[3]


def _config(tmp_path: Path, **change: object) -> Path:
    doc = {
        "format": "sim2real.train/1",
        "env": {"id": "RandomMap-v0", "kwargs": {"preset": "TEST1", "max_episode_steps": 40}},
        "randomizers": str(ROOT / "examples" / "randommap_randomizers.yaml"),
        "algorithm": "PPO",
        "hyperparameters": {"n_steps": 64, "batch_size": 32, "n_epochs": 1},
        "timesteps": 128,
        "n_envs": 2,
        "vec_env": "dummy",
        "seed": 0,
        "out": str(tmp_path / "run"),
        "checkpoint_every": 64,
        "evaluation": {"episodes": 2, "seed": 100},
        **change,
    }
    path = tmp_path / "train.yaml"
    path.write_text(yaml.safe_dump(doc), encoding="utf-8")
    return path


def test_train_writes_every_output(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cfg = _config(tmp_path)
    assert main(["train", str(cfg), "--timesteps", "128", "--seed", "4"]) == 0
    out = tmp_path / "run"
    assert "trained 128 steps" in capsys.readouterr().out
    resolved = yaml.safe_load((out / "config.yaml").read_text())
    assert resolved["seed"] == 4 and resolved["timesteps"] == 128
    # the randomizer stack is written out in full (types, arguments, names)
    assert [r["name"] for r in resolved["randomizers"]["randomizers"]] == [
        "DynamicsRandomizer",
        "LidarNoise[0:36]",
        "GoalNoise[36:38]",
        "OdometryDelay[38:40]",
    ]
    assert sorted(p.name for p in (out / "checkpoints").iterdir()) == [
        "model_128_steps.zip",
        "model_64_steps.zip",
    ]
    assert any((out / "tensorboard").rglob("events.out.tfevents.*"))
    with zipfile.ZipFile(out / "model.zip") as zf:
        meta = yaml.safe_load(zf.read("sim2real.yaml"))
    assert meta["algorithm"] == "PPO" and meta["env_id"] == "sim2real/RandomMap-v0"
    assert meta["observation_space"] == "Box(40,)"
    ev = yaml.safe_load((out / "evaluation.yaml").read_text())
    assert ev["episodes"] == 2 and ev["seeds"] == [100, 101]
    assert ev["success_rate"] + ev["collision_rate"] + ev["timeout_rate"] == pytest.approx(1.0)


def test_same_seed_same_policy(tmp_path: Path) -> None:
    from stable_baselines3 import PPO

    params = []
    for run in ("a", "b", "c"):
        seed = 1 if run != "c" else 2
        cfg = _config(tmp_path, out=str(tmp_path / run), checkpoint_every=0, timesteps=64)
        assert main(["train", str(cfg), "--seed", str(seed)]) == 0
        model = PPO.load(str(tmp_path / run / "model.zip"), device="cpu")
        params.append(next(iter(model.policy.parameters())).detach().numpy().copy())
    assert (params[0] == params[1]).all()
    assert not (params[0] == params[2]).all()


def test_eval_policy_and_mismatched_env(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cfg = _config(tmp_path, checkpoint_every=0, timesteps=64, randomizers=None)
    assert main(["train", str(cfg)]) == 0
    model = str(tmp_path / "run" / "model.zip")
    capsys.readouterr()
    report = tmp_path / "eval.json"
    argv = ["envs", "eval", "RandomMap-v0", "--policy", model, "--episodes", "2"]
    assert main([*argv, "--preset", "TEST1", "--json", str(report)]) == 0
    doc = json.loads(report.read_text())
    assert doc["controller"] == "PPO policy model.zip" and len(doc["episodes"]) == 2
    assert "PPO policy model.zip on" in capsys.readouterr().out
    # a policy trained on RandomMap cannot drive CrowdNav
    assert main(["envs", "eval", "CrowdNav-v0", "--policy", model, "--episodes", "1"]) == 2
    err = capsys.readouterr().err
    assert (
        f"policy '{model}' was trained on sim2real/RandomMap-v0, not sim2real/CrowdNav-v0; "
        "evaluate it on RandomMap-v0" in err
    )
    assert err.count("\n") == 1
    # not a model at all
    bogus = tmp_path / "bogus.zip"
    bogus.write_bytes(b"not a zip")
    assert main(["envs", "eval", "RandomMap-v0", "--policy", str(bogus)]) == 2
    assert "is not a zip file" in capsys.readouterr().err


def test_normalized_policy_logs_episodes_and_evaluates_scaled(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from stable_baselines3.common.vec_env import VecNormalize

    from sim2real.training._sb3 import _vec_env
    from sim2real.training.config import load_config
    from sim2real.training.environment import build_env
    from sim2real.training.evaluation import evaluate_controller, load_policy

    cfg = _config(tmp_path, checkpoint_every=0, timesteps=256, randomizers=None, normalize=True)
    assert isinstance(_vec_env(load_config(cfg)), VecNormalize)  # rewards: training only
    assert main(["train", str(cfg)]) == 0
    out = tmp_path / "run"
    lines = (out / "episodes.csv").read_text().splitlines()
    assert lines[0] == "step,outcome,return,length"
    rows = [line.split(",") for line in lines[1:]]
    assert len(rows) >= 256 // 40  # 40-step episodes at most
    steps = [int(r[0]) for r in rows]
    assert steps == sorted(steps) and steps[-1] <= 256
    assert {r[1] for r in rows} <= {"success", "crash", "trap"}
    assert sum(int(r[3]) for r in rows) <= 256
    policy = load_policy(out / "model.zip")
    assert policy.metadata["normalize"] == {"observations": True, "actions": True}
    assert policy.model.observation_space.high.max() == 1.0
    # envs eval applies the policy's scaling: the same episodes as by hand
    capsys.readouterr()
    report = tmp_path / "eval.json"
    argv = ["envs", "eval", "RandomMap-v0", "--policy", str(out / "model.zip")]
    assert main([*argv, "--episodes", "2", "--seed", "7", "--json", str(report)]) == 0
    by_cli = json.loads(report.read_text())["episodes"]
    env = policy.wrap(build_env("sim2real/RandomMap-v0", policy.metadata["env_kwargs"]))
    by_hand = evaluate_controller(env, policy.controller(), episodes=2, seed=7).per_episode
    assert [e["success"] for e in by_cli] == [e["success"] for e in by_hand]
    assert [e["return"] for e in by_cli] == pytest.approx([e["return"] for e in by_hand])


def test_dqn_gets_an_action_grid_and_evaluates(tmp_path: Path) -> None:
    cfg = _config(
        tmp_path,
        algorithm="DQN",
        n_envs=1,
        hyperparameters={"learning_starts": 16, "buffer_size": 500},
        timesteps=64,
        checkpoint_every=0,
    )
    assert main(["train", str(cfg)]) == 0
    with zipfile.ZipFile(tmp_path / "run" / "model.zip") as zf:
        meta = yaml.safe_load(zf.read("sim2real.yaml"))
    assert len(meta["discrete_actions"]["v_mps"]) == 3
    assert len(meta["discrete_actions"]["w_radps"]) == 5
    model = str(tmp_path / "run" / "model.zip")
    assert main(["envs", "eval", "RandomMap-v0", "--policy", model, "--episodes", "1"]) == 0


@pytest.mark.parametrize("algorithm", ["SAC", "TD3"])
def test_off_policy_continuous_algorithms_train_and_evaluate(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], algorithm: str
) -> None:
    """SAC and TD3 (continuous v, w) through the same config, outputs and evaluation as PPO."""
    cfg = _config(
        tmp_path,
        algorithm=algorithm,
        hyperparameters={"learning_starts": 32, "batch_size": 16, "buffer_size": 500},
        timesteps=96,
    )
    assert main(["train", str(cfg)]) == 0
    assert f"training {algorithm} on sim2real/RandomMap-v0 for 96 steps" in capsys.readouterr().out
    out = tmp_path / "run"
    with zipfile.ZipFile(out / "model.zip") as zf:
        meta = yaml.safe_load(zf.read("sim2real.yaml"))
    assert meta["algorithm"] == algorithm and meta["discrete_actions"] is None
    assert sorted(p.name for p in (out / "checkpoints").iterdir()) == ["model_64_steps.zip"]
    report = tmp_path / "eval.json"
    argv = ["envs", "eval", "RandomMap-v0", "--policy", str(out / "model.zip"), "--episodes", "1"]
    assert main([*argv, "--json", str(report)]) == 0
    assert json.loads(report.read_text())["controller"] == f"{algorithm} policy model.zip"


def test_robustness_with_a_policy(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cfg = _config(tmp_path, checkpoint_every=0, timesteps=64, randomizers=None)
    assert main(["train", str(cfg)]) == 0
    capsys.readouterr()
    out = tmp_path / "rob.json"
    argv = ["envs", "robustness", "RandomMap-v0", "--policy", str(tmp_path / "run" / "model.zip")]
    rand = tmp_path / "dr.yaml"
    rand.write_text(
        yaml.safe_dump(
            {
                "format": "sim2real.randomizers/1",
                "randomizers": [
                    {"type": "ActionDelay", "delay_steps": 3},
                    {"type": "LidarNoise", "index": [0, 36], "std_m": 0.05, "name": "lidar"},
                ],
            }
        )
    )
    argv += ["--randomize", str(rand), "--episodes", "2", "--preset", "TEST1"]
    assert main([*argv, "--json", str(out)]) == 0
    rows = json.loads(out.read_text())["rows"]
    assert [r["condition"] for r in rows] == ["none", "ActionDelay", "lidar", "all"]
    for r in rows:
        lo, hi = r["success_ci95"]
        assert 0.0 <= lo <= r["success_rate"] <= hi <= 1.0
        assert r["success_rate"] + r["collision_rate"] + r["timeout_rate"] == pytest.approx(1.0)


def test_eval_uses_the_settings_saved_with_the_policy(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A policy trained at a 0.25 s control period with 12-step episodes evaluates so."""
    kwargs = {"preset": "TEST1", "max_episode_steps": 12, "control_dt": 0.25}
    env = {"id": "RandomMap-v0", "kwargs": kwargs}
    cfg = _config(tmp_path, checkpoint_every=0, timesteps=64, randomizers=None, env=env)
    assert main(["train", str(cfg)]) == 0
    model = str(tmp_path / "run" / "model.zip")
    capsys.readouterr()
    report = tmp_path / "eval.json"
    argv = ["envs", "eval", "RandomMap-v0", "--policy", model, "--episodes", "3"]
    assert main([*argv, "--json", str(report)]) == 0
    out = capsys.readouterr().out
    applied = "note: env settings of the policy: control_dt 0.25, max_episode_steps 12"
    assert f"{applied}, preset TEST1\n" in out and "replaces" not in out
    episodes = json.loads(report.read_text())["episodes"]
    for e in episodes:  # 0.25 s steps, 12 of them for a trap
        assert e["episode_time_s"] == pytest.approx(0.25 * e["steps"]) and e["steps"] <= 12
        assert e["outcome"] != "trap" or e["steps"] == 12
    # a flag replaces its saved setting, with a note; the others stay the policy's
    assert main([*argv, "--preset", "TEST2", "--dynamics", "plant", "--json", str(report)]) == 0
    out = capsys.readouterr().out
    assert "note: --preset TEST2 replaces the policy's training setting TEST1" in out
    assert f"{applied}\n" in out
    test2 = json.loads(report.read_text())
    assert test2["dynamics"] == "plant" and all(e["steps"] <= 12 for e in test2["episodes"])
    assert main([*argv, "--dynamics", "plant", "--json", str(report)]) == 0
    test1 = json.loads(report.read_text())  # the same seeds on the policy's own TEST1 maps
    assert "replaces" not in capsys.readouterr().out
    assert [e["path_length_m"] for e in test1["episodes"]] != [
        e["path_length_m"] for e in test2["episodes"]
    ]


def test_eval_refuses_a_missing_params_file_of_the_policy(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    fit = tmp_path / "fit.yaml"
    fit.write_text(
        yaml.safe_dump(
            {
                "format": "sim2real.sysid/1",
                "robot": "turtlebot3_burger",
                "parameters": {"delay_s": {"value": 0.1, "std": 0.0, "status": "fitted"}},
            }
        )
    )
    env = {"id": "RandomMap-v0", "kwargs": {"preset": "TEST1", "params": str(fit)}}
    cfg = _config(tmp_path, checkpoint_every=0, timesteps=64, randomizers=None, env=env)
    assert main(["train", str(cfg)]) == 0
    model = str(tmp_path / "run" / "model.zip")
    fit.unlink()
    capsys.readouterr()
    argv = ["envs", "eval", "RandomMap-v0", "--policy", model, "--episodes", "1"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert f"was trained with params file '{fit}', which does not exist here" in err
    # on the plant the drive parameters do not apply: evaluated, with a note
    assert main([*argv, "--dynamics", "plant"]) == 0
    assert "is not applied: --dynamics plant has its own physics" in capsys.readouterr().out


def test_td3_trains_with_the_configured_action_noise(tmp_path: Path) -> None:
    from stable_baselines3.common.noise import NormalActionNoise, OrnsteinUhlenbeckActionNoise

    from sim2real.training import _sb3
    from sim2real.training.config import load_config
    from sim2real.training.environment import build_env

    noise = {"type": "normal", "sigma": 0.3}
    change = {"algorithm": "TD3", "hyperparameters": {"learning_starts": 50, "batch_size": 16}}
    cfg = load_config(_config(tmp_path, **change, action_noise=noise, randomizers=None))
    probe = build_env(cfg.env_id, cfg.env_kwargs)
    model, _, _ = _sb3.learn(cfg, probe)
    base = model.action_noise.base_noise  # SB3's VecNoise, one copy per env
    assert isinstance(base, NormalActionNoise) and base._sigma.tolist() == [0.3, 0.3]  # (v, w)
    ou = _sb3.action_noise({"type": "ornstein-uhlenbeck", "sigma": 0.2}, probe.action_space)
    assert isinstance(ou, OrnsteinUhlenbeckActionNoise) and ou._sigma.tolist() == [0.2, 0.2]
    # the noise is what the robot gets: TD3's (deterministic) actor, sampled five times from one
    # observation past learning_starts, gives five different training actions
    noisy = [model._sample_action(0, model.action_noise, 2)[1] for _ in range(5)]
    assert len({a.tobytes() for a in noisy}) == 5


def test_a_goal_curriculum_moves_the_envs_goal_to_their_own_values(
    tmp_path: Path,
) -> None:
    from sim2real.training import _sb3
    from sim2real.training.config import load_config
    from sim2real.training.environment import build_env

    kwargs = {"preset": "TEST1", "max_episode_steps": 40, "goal_speed_mps": 0.05}
    change = {"env": {"id": "RandomMap-v0", "kwargs": kwargs}, "randomizers": None}
    curriculum = {"goal_speed_mps": 0.8, "goal_tolerance_m": 1.2, "until": 0.5}
    cfg = load_config(_config(tmp_path, **change, timesteps=512, curriculum=curriculum))
    seen: list[tuple[int, float, float]] = []

    class Spy(_sb3.Curriculum):
        def _on_rollout_start(self) -> None:
            super()._on_rollout_start()
            speed, tol = (
                self.training_env.get_attr(k) for k in ("goal_speed_mps", "goal_tolerance_m")
            )
            assert len(set(speed)) == len(set(tol)) == 1  # every env follows
            seen.append((int(self.num_timesteps), speed[0], tol[0]))

    real = _sb3.Curriculum
    _sb3.Curriculum = Spy  # type: ignore[misc]
    try:
        _sb3.learn(cfg, build_env(cfg.env_id, cfg.env_kwargs))
    finally:
        _sb3.Curriculum = real  # type: ignore[misc]
    # rollouts of 2 x 64 steps: 0, 128, 256, 384; the own values (0.05 m/s, TEST1's 0.3 m) at
    # 256 = 0.5 x 512 and after; geometric in between
    assert [s for s, _, _ in seen] == [0, 128, 256, 384]
    assert seen[0][1:] == pytest.approx((0.8, 1.2))
    assert seen[1][1:] == pytest.approx(((0.8 * 0.05) ** 0.5, (1.2 * 0.3) ** 0.5))
    assert seen[2][1:] == seen[3][1:] == pytest.approx((0.05, 0.3))


def test_a_crowd_curriculum_holds_the_empty_room_then_grows_the_crowd(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from sim2real.training import _sb3
    from sim2real.training.config import load_config
    from sim2real.training.environment import build_env

    kwargs = {"complexity": 0.5, "depth_width": 8, "depth_height": 6, "max_episode_steps": 40}
    change = {"env": {"id": "CrowdNav-v0", "kwargs": kwargs}, "randomizers": None}
    curriculum = {"complexity": 0.1, "scenario": "static", "hold": 0.25, "until": 0.75}
    cfg = load_config(_config(tmp_path, **change, timesteps=512, curriculum=curriculum))
    seen: list[tuple[int, str, float, int]] = []

    class Spy(_sb3.Curriculum):
        def _on_rollout_start(self) -> None:
            super()._on_rollout_start()
            scenario, c = (self.training_env.get_attr(k) for k in ("scenario", "complexity"))
            assert len(set(scenario)) == len(set(c)) == 1  # every env follows
            # the next episode is built with them
            peds = self.training_env.env_method("reset", seed=1)[0][1]["num_pedestrians"]
            seen.append((int(self.num_timesteps), scenario[0], c[0], peds))

    monkeypatch.setattr(_sb3, "Curriculum", Spy)
    _sb3.learn(cfg, build_env(cfg.env_id, cfg.env_kwargs))
    # rollouts of 2 x 64 steps: 0, 128, 256, 384; the empty room before 128 = 0.25 x 512, then
    # the env's own dynamic scenario, complexity 0.1 -> 0.5 linearly by 384 = 0.75 x 512
    assert [(s, sc) for s, sc, _, _ in seen] == [
        (0, "static"),
        (128, "dynamic"),
        (256, "dynamic"),
        (384, "dynamic"),
    ]
    assert [c for _, _, c, _ in seen] == pytest.approx([0.1, 0.1, 0.3, 0.5])
    assert [p for _, _, _, p in seen] == [0, round(5 + 1.5), round(5 + 4.5), round(5 + 7.5)]


@pytest.mark.parametrize(
    ("curriculum", "says"),
    [
        (
            {"goal_speed_mps": 0.7},
            "the env's own goal_speed_mps is inf (passing through the goal counts)",
        ),
        (
            {"complexity": 0.0},
            "key 'curriculum' grows a crowd's complexity, which sim2real/RandomMap-v0",
        ),
    ],
)
def test_a_curriculum_the_env_cannot_follow_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], curriculum: dict, says: str
) -> None:
    cfg = _config(tmp_path, randomizers=None, curriculum=curriculum)
    assert main(["train", str(cfg)]) == 2
    err = capsys.readouterr().err
    assert says in err
    assert "Traceback" not in err


def test_episodes_csv_is_written_while_training_goes(tmp_path: Path) -> None:
    from sim2real.training import _sb3
    from sim2real.training.config import load_config
    from sim2real.training.environment import build_env

    cfg = load_config(_config(tmp_path, timesteps=256, randomizers=None, checkpoint_every=0))
    seen: list[int] = []
    probe = build_env(cfg.env_id, cfg.env_kwargs)
    _, rows, _ = _sb3.learn(cfg, probe, on_episodes=lambda r: seen.append(len(r)), every_s=0.0)
    assert seen[0] == 0 and seen[-1] == len(rows) >= 256 // 40  # header first, all rows last
    assert len(seen) >= len(rows)  # every episode, with every_s = 0
    assert seen == sorted(seen)
    quiet: list[int] = []
    probe = build_env(cfg.env_id, cfg.env_kwargs)
    _sb3.learn(cfg, probe, on_episodes=lambda r: quiet.append(1), every_s=3600.0)
    assert len(quiet) == 2  # at the start and at the end only
