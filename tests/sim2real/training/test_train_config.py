"""Training config parsing (`sim2real.training.config`), env construction
(`sim2real.training.environment`) and the CLI's bad-input paths.

These tests do not need the [train] extra: the config is read and checked before any import of
torch or stable-baselines3.
"""

from __future__ import annotations

import json
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml

import randomizers as dr
from robots.errors import ParamsFileError
from sim2real.cli import main
from sim2real.errors import Sim2RealValueError
from sim2real.training.config import config_from_dict, load_config
from sim2real.training.environment import DiscreteActions, build_env
from sim2real.training.evaluation import wilson_interval

ROOT = Path(__file__).resolve().parents[3]


def _write(path: Path, doc: object) -> Path:
    path.write_text(yaml.safe_dump(doc), encoding="utf-8")
    return path


def test_example_configs_load_with_overrides() -> None:
    cfg = load_config(ROOT / "examples" / "randommap_ppo.yaml", timesteps=2000, seed=7, out="x")
    assert (cfg.env_id, cfg.algorithm, cfg.timesteps, cfg.seed, cfg.out) == (
        "sim2real/RandomMap-v0",
        "PPO",
        2000,
        7,
        Path("x"),
    )
    assert cfg.n_envs == 2 and cfg.hyperparameters["n_steps"] == 256
    # the randomizer file is resolved relative to the config and read in
    assert [e["type"] for e in cfg.randomizers["randomizers"]] == [
        "DynamicsRandomizer",
        "LidarNoise",
        "GoalNoise",
        "OdometryDelay",
    ]
    crowd = load_config(ROOT / "examples" / "crowdnav_ppo.yaml")
    assert crowd.env_id == "sim2real/CrowdNav-v0" and crowd.env_kwargs["scenario"] == "dynamic"
    car = load_config(ROOT / "examples" / "carcrossing_dqn.yaml")
    assert (car.env_id, car.algorithm) == ("sim2real/CarCrossing-v0", "DQN")
    # every example's env and randomizer stack builds
    for c in (cfg, crowd, car):
        env = build_env(c.env_id, c.env_kwargs, randomizers=c.randomizers)
        env.reset(seed=0)
        env.close()


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"algorithm": "A2C"}, r"key 'algorithm' is 'A2C', which is not supported; use one of PPO"),
        ({"env": {"id": "Nope-v9"}}, r"env id 'Nope-v9' is not a sim2real env; known envs are"),
        ({"timesteps": 0}, r"key 'timesteps' must be an integer >= 1, got 0"),
        ({"n_envs": "two"}, r"key 'n_envs' must be an integer >= 1, got 'two'"),
        ({"vec_env": "threads"}, r"key 'vec_env' must be one of subproc, dummy, got 'threads'"),
        ({"lr": 1}, r"unknown key\(s\) \['lr'\]"),
        ({"format": "other/1"}, r"key 'format' must be 'sim2real.train/1'"),
        (  # a sysid result given as the training config: its format says what it is
            {"format": "sim2real.sysid/1", "parameters": {}, "robot": "x"},
            r"key 'format' must be 'sim2real.train/1', got 'sim2real.sysid/1'",
        ),
        ({"discrete_actions": {"v_mps": []}}, r"key 'discrete_actions' must be"),
        ({"normalize": {"obs": True}}, r"key 'normalize' must be true, false or a mapping of"),
        ({"normalize": {"rewards": "yes"}}, r"key 'normalize' must be .* got \{'rewards': 'yes'\}"),
        (
            {"algorithm": "TD3", "action_noise": {"type": "normal", "sigma": -0.1}},
            r"key 'action_noise' must be \{type: normal or ornstein-uhlenbeck, sigma: a number "
            r"> 0\} \(the noise's standard deviation in action units\), got .*-0.1",
        ),
        (
            {"algorithm": "TD3", "action_noise": {"type": "uniform", "sigma": 0.1}},
            r"key 'action_noise' must be .* got \{'type': 'uniform'",
        ),
        ({"algorithm": "SAC", "action_noise": {"sigma": 0.1}}, r"key 'action_noise' must be"),
        (
            {"algorithm": "TD3", "action_noise": {"type": "normal", "sigma": float("nan")}},
            r"key 'action_noise' must be",
        ),
        (
            {"action_noise": {"type": "normal", "sigma": 0.1}},
            r"key 'action_noise' applies to SAC and TD3 only, not PPO; remove the key",
        ),
        (
            {"curriculum": {"goal_speed_mps": -0.7}},
            r"key 'curriculum' must map goal_speed_mps and/or goal_tolerance_m to the start "
            r"value \(a number > 0\) .* got \{'goal_speed_mps': -0.7\}; e.g. curriculum: ",
        ),
        ({"curriculum": {"until": 0.5}}, r"key 'curriculum' must map goal_speed_mps"),
        ({"curriculum": {"goal_speed_mps": 0.7, "until": 1.5}}, r"key 'curriculum' must map"),
        (
            {"curriculum": {"goal_speed": 0.7}},
            r"key 'curriculum' must map .* got \{'goal_speed': 0.7\}",
        ),
        ({"curriculum": {"goal_speed_mps": True}}, r"key 'curriculum' must map"),
        ({"curriculum": {"complexity": 1.5}}, r"key 'curriculum' must map .* in \[0, 1\]"),
        (
            {"curriculum": {"complexity": 0.0, "hold": 0.6, "until": 0.5}},
            r"hold to a share below until",
        ),
        (
            {"curriculum": {"complexity": 0.0, "scenario": "empty"}},
            r"with hold, scenario to one of static, dynamic, occluded; got",
        ),
        ({"curriculum": {"goal_speed_mps": 0.7, "hold": 0.2}}, r"key 'curriculum' must map"),
        (
            {"algorithm": "rllib-ppo", "curriculum": {"goal_speed_mps": 0.7}},
            r"key 'curriculum' applies to the stable-baselines3 algorithms .* not rllib-ppo",
        ),
    ],
)
def test_bad_config_is_one_sentence(change: dict, match: str) -> None:
    doc = {"env": {"id": "RandomMap-v0"}, "algorithm": "PPO", **change}
    with pytest.raises(Sim2RealValueError, match=match):
        config_from_dict(doc)


@pytest.mark.parametrize(
    ("change", "needle"),
    [
        ({"algorithm": "A3C"}, "key 'algorithm' is 'A3C', which is not supported"),
        ({"env": {"id": "Atlantis-v5"}}, "env id 'Atlantis-v5' is not a sim2real env"),
        (
            {"algorithm": "TD3", "action_noise": {"type": "normal", "sigma": 0}},
            "key 'action_noise' must be {type: normal or ornstein-uhlenbeck, sigma: a number > 0}",
        ),
    ],
)
def test_cli_bad_config_exits_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], change: dict, needle: str
) -> None:
    cfg = _write(tmp_path / "c.yaml", {"env": {"id": "RandomMap-v0"}, **change})
    assert main(["train", str(cfg), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert needle in err and "Traceback" not in err and err.count("\n") == 1
    assert not (tmp_path / "o").exists()


def test_cli_unknown_env_in_eval_exits_2(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["envs", "eval", "Nowhere-v0", "--episodes", "1"]) == 2
    assert "unknown env 'Nowhere-v0'" in capsys.readouterr().err


def test_normalize_rescales_the_spaces_to_unit_bounds() -> None:
    import numpy as np

    cfg = config_from_dict({"env": {"id": "RandomMap-v0"}, "normalize": True})
    assert cfg.normalize == {"observations": True, "actions": True, "rewards": True}
    part = config_from_dict({"env": {"id": "RandomMap-v0"}, "normalize": {"actions": True}})
    assert part.normalize == {"observations": False, "actions": True, "rewards": False}
    raw = build_env("sim2real/RandomMap-v0", {"preset": "TEST1"})
    env = build_env("sim2real/RandomMap-v0", {"preset": "TEST1"}, normalize=cfg.normalize)
    assert env.observation_space.low.min() == -1.0 and env.observation_space.high.max() == 1.0
    obs_raw, _ = raw.reset(seed=3)
    obs, _ = env.reset(seed=3)
    low, high = raw.observation_space.low, raw.observation_space.high
    np.testing.assert_allclose(obs, 2 * (obs_raw - low) / (high - low) - 1, atol=1e-6)
    # action -1 is the env's lowest command (v 0 m/s, w -1 rad/s), +1 its highest
    assert env.action_space.low.tolist() == [-1.0, -1.0]
    assert env.unwrapped.action_space.high.tolist() == pytest.approx([0.21, 1.0])
    with pytest.raises(Sim2RealValueError, match="normalize 'observations' needs a Box"):
        build_env("CartPole-v1", {}, normalize={"observations": True})  # unbounded velocities


def test_normalize_rescales_every_entry_of_a_dict_observation() -> None:
    import numpy as np

    kwargs = {"depth_width": 8, "depth_height": 6, "neighbours": 2}
    raw = build_env("sim2real/CrowdNav-v0", kwargs)
    env = build_env("sim2real/CrowdNav-v0", kwargs, normalize={"observations": True})
    assert set(env.observation_space.spaces) == set(raw.observation_space.spaces)
    obs_raw, _ = raw.reset(seed=4)
    obs, _ = env.reset(seed=4)
    for key, box in raw.observation_space.spaces.items():
        assert env.observation_space[key].shape == box.shape
        want = 2 * (np.clip(obs_raw[key], box.low, box.high) - box.low) / (box.high - box.low) - 1
        np.testing.assert_allclose(obs[key], want, atol=1e-6)
    # the goal distance (0-20 m) at the start, 6 m across the room at most: below the midpoint
    assert -1.0 < float(obs["goal"][0]) < -0.3
    # the room's walls are inside the lidar's 8 m: every reading is strictly inside the scale
    assert float(obs["lidar"].min()) > -1.0 and float(obs["lidar"].max()) < 1.0


def test_action_noise_is_read_and_written_back() -> None:
    doc = {
        "env": "RandomMap-v0",
        "algorithm": "td3",
        "action_noise": {"type": "normal", "sigma": 1},
    }
    cfg = config_from_dict(doc)
    assert cfg.action_noise == {"type": "normal", "sigma": 1.0}
    assert config_from_dict(cfg.to_dict()).action_noise == cfg.action_noise
    assert config_from_dict({"env": "RandomMap-v0"}).action_noise is None


def test_override_values_are_checked() -> None:
    with pytest.raises(Sim2RealValueError, match=r"--timesteps: key 'timesteps' must be"):
        config_from_dict({"env": "RandomMap-v0"}, timesteps=-5)


def test_sysid_paths_resolve_relative_to_the_config(tmp_path: Path) -> None:
    sub = tmp_path / "cfg"
    sub.mkdir()
    doc = {
        "env": {"id": "RandomMap-v0", "kwargs": {"params": "fit.yaml"}},
        "randomizers": [{"type": "DynamicsRandomizer", "sysid": "fit.yaml"}],
    }
    cfg = load_config(_write(sub / "train.yaml", doc))
    assert cfg.randomizers["randomizers"][0]["sysid"] == str((sub / "fit.yaml").resolve())
    assert cfg.env_kwargs["params"] == str((sub / "fit.yaml").resolve())


def _sysid_result(path: Path, robot: str = "turtlebot3_burger") -> Path:
    doc = {
        "format": "sim2real.sysid/1",
        "robot": robot,
        "parameters": {
            "delay_s": {"value": 0.2, "std": 0.01, "status": "fitted"},
            "added_mass_kg": {"value": 0.5, "std": 0.05, "status": "fitted"},
        },
    }
    return _write(path, doc)


def test_randomizer_config_builds_dynamics_from_a_sysid_result(tmp_path: Path) -> None:
    from robots.randomization import DriveDistribution
    from robots.spec import load_spec
    from tests.randomization_block import write_params_file

    centre = load_spec("turtlebot3_burger").drive.replace(delay_s=0.2, added_mass_kg=0.5)
    fit = write_params_file(tmp_path / "fit.yaml", centre, "turtlebot3_burger")
    sd = DriveDistribution.from_params_file(fit, robot="turtlebot3_burger").std()["delay_s"]
    cfg_path = _write(
        tmp_path / "dr.yaml",
        {
            "format": dr.CONFIG_FORMAT,
            "randomizers": [{"type": "DynamicsRandomizer", "sysid": "fit.yaml", "scale": 0.5}],
        },
    )
    env = dr.from_config(gym.make("sim2real/RandomMap-v0", preset="TEST1"), cfg_path)
    saved = dr.to_config(env)["randomizers"][0]
    assert saved["sysid"] == str(fit) and saved["robot"] == "turtlebot3_burger"
    assert saved["scale"] == 0.5
    _, info = env.reset(seed=3)
    drawn = info["randomization"]["DynamicsRandomizer"]
    assert abs(drawn["delay_s"] - 0.2) < 0.5 * sd * 4 and drawn["delay_s"] != 0.2
    assert env.unwrapped.get_drive_params().delay_s == drawn["delay_s"]
    with pytest.raises(dr.errors.RandomizerConfigError, match=r"key 'sysid' names '.*nope.yaml'"):
        dr.from_config(
            gym.make("sim2real/RandomMap-v0"),
            {
                "format": dr.CONFIG_FORMAT,
                "randomizers": [{"type": "DynamicsRandomizer", "sysid": "nope.yaml"}],
            },
            base_dir=tmp_path,
        )


def test_build_env_params_file_and_map_config(tmp_path: Path) -> None:
    fit = _sysid_result(tmp_path / "fit.yaml")
    env = build_env(
        "sim2real/RandomMap-v0",
        {
            "params": str(fit),
            "map_config": {"d_target_m": 2.0, "n_min": 0, "n_max": 3},
            "max_episode_steps": 25,
        },
    )
    base = env.unwrapped
    assert base.get_drive_params().delay_s == 0.2
    assert base.get_drive_params().added_mass_kg == 0.5
    assert base.map_config.d_target_m == 2.0 and base.max_episode_steps == 25
    # max_episode_steps reaches the env (no gymnasium TimeLimit): the env's own timeout ends it
    env.reset(seed=0)
    for _ in range(25):
        _, _, term, trunc, info = env.step(np.zeros(2))
    assert term or trunc
    assert info["metrics"]["outcome"] == "timeout"
    other = _sysid_result(tmp_path / "tb2.yaml", robot="turtlebot2")
    with pytest.raises(ParamsFileError, match="identified for robot 'turtlebot2'"):
        build_env("sim2real/RandomMap-v0", {"params": str(other)})


def test_discrete_actions_grid() -> None:
    env = DiscreteActions(
        gym.make("sim2real/RandomMap-v0"), v_mps=[0.0, 0.1, 0.2], w_radps=[-1.0, 1.0]
    )
    assert env.action_space == gym.spaces.Discrete(6)
    np.testing.assert_array_equal(env.action(5), np.float32([0.2, 1.0]))
    np.testing.assert_array_equal(env.action(np.int64(2)), np.float32([0.1, -1.0]))


def test_wilson_interval_known_values() -> None:
    # Wilson (1927); e.g. 8/10 -> [0.490, 0.943] at 95 %
    lo, hi = wilson_interval(8, 10)
    assert (round(lo, 3), round(hi, 3)) == (0.49, 0.943)
    assert wilson_interval(10, 10)[1] == pytest.approx(1.0)
    # all or none: the interval holds its rate exactly (float rounding put 1 outside at n=4)
    for n in range(1, 201):
        assert wilson_interval(n, n)[1] == 1.0 and wilson_interval(0, n)[0] == 0.0
    lo, hi = wilson_interval(0, 5)
    assert lo == 0.0 and 0.4 < hi < 0.45


def test_eval_params_file_changes_the_robot(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """--params gives the env the result's drive parameters: a 1 s delay is visible in v."""
    fit = _write(
        tmp_path / "slow.yaml",
        {
            "format": "sim2real.sysid/1",
            "robot": "turtlebot3_burger",
            "parameters": {"delay_s": {"value": 1.0, "std": 0.0, "status": "fitted"}},
        },
    )
    rows = {}
    for label, extra in (("nominal", []), ("slow", ["--params", str(fit)])):
        out = tmp_path / f"{label}.json"
        argv = ["envs", "eval", "RandomMap-v0", "--episodes", "1", "--preset", "TEST1"]
        assert main([*argv, *extra, "--json", str(out)]) == 0
        rows[label] = json.loads(out.read_text())
    assert rows["slow"]["params"] == str(fit)
    assert rows["slow"]["episodes"][0] != rows["nominal"]["episodes"][0]
    shown = " ".join(capsys.readouterr().out.split())  # the table's title names the robot
    assert shown.count("params slow.yaml") == 1
    other = _sysid_result(tmp_path / "tb2.yaml", robot="turtlebot2")
    argv = ["envs", "eval", "RandomMap-v0", "--episodes", "1", "--params", str(other)]
    assert main(argv) == 2
    assert "identified for robot 'turtlebot2', not 'turtlebot3_burger'" in capsys.readouterr().err


def test_cli_train_without_the_extra_says_how_to_install(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    import sim2real.training.config

    monkeypatch.setattr(sim2real.training.config, "_importable", lambda module: module != "torch")
    cfg = _write(tmp_path / "c.yaml", {"env": {"id": "RandomMap-v0"}, "algorithm": "PPO"})
    assert main(["train", str(cfg), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "sim2real train needs torch, which is not installed" in err[0]
    assert "pip install torch==2.13.0 && pip install -e '.[train]'" in err[0]
    assert "make train-extra" in err[0]


def test_curriculum_fills_in_until_and_round_trips() -> None:
    doc = {"env": {"id": "RandomMap-v0"}, "curriculum": {"goal_tolerance_m": 1}}
    cfg = config_from_dict(doc)
    assert cfg.curriculum == {"goal_tolerance_m": 1.0, "until": 0.5}
    assert config_from_dict(cfg.to_dict()).curriculum == cfg.curriculum
    assert config_from_dict({"env": {"id": "RandomMap-v0"}}).curriculum is None


def test_a_crowd_curriculum_round_trips() -> None:
    start = {"complexity": 0, "scenario": "static", "hold": 0.2, "until": 0.5}
    cfg = config_from_dict({"env": {"id": "CrowdNav-v0"}, "curriculum": start})
    assert cfg.curriculum == {"complexity": 0.0, "hold": 0.2, "scenario": "static", "until": 0.5}
    assert config_from_dict(cfg.to_dict()).curriculum == cfg.curriculum
