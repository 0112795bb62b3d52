"""LidarNoise drawn per episode from a `sim2real sysid sensors` result."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
import yaml

from randomizers import LidarNoise, OdometryDelay, from_config, to_config
from randomizers.errors import RandomizerConfigError
from sysid.sensors import estimate_sensor
from tests.sysid.sensor_truth import MOUNT_XY_M, draw_truth, synthetic_recording

RANGE_M = 2.0


class Scan(gym.Env[Any, Any]):
    """Every beam sees a wall at 2 m."""

    observation_space = gym.spaces.Box(0.06, 5.0, (2000,), np.float32)
    action_space = gym.spaces.Discrete(1)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> Any:
        super().reset(seed=seed)
        return np.full(2000, RANGE_M, np.float32), {}

    def step(self, action: Any) -> Any:
        return np.full(2000, RANGE_M, np.float32), 0.0, False, False, {}


@pytest.fixture(scope="module")
def sensors_yaml(tmp_path_factory: pytest.TempPathFactory) -> Path:
    scans, odom = synthetic_recording(draw_truth(np.random.default_rng(5)), 5, duration_s=30.0)
    path = tmp_path_factory.mktemp("sensors") / "sensors.yaml"
    estimate_sensor(scans, odom, mount_xy_m=MOUNT_XY_M, n_boot=50).save(path)
    return path


def test_each_episode_draws_its_noise_around_the_identified_values(sensors_yaml: Path) -> None:
    data = yaml.safe_load(sensors_yaml.read_text())
    env = LidarNoise.from_sysid(sensors_yaml, env=Scan(), spread=5.0)
    draws = []
    for episode in range(12):
        obs, info = env.reset(seed=episode)
        rec = info["randomization"]["LidarNoise"]
        kept = obs[obs < 5.0]
        sigma = rec["std_m"] + (rec["std_per_m"] + rec["std_per_m2"] * RANGE_M) * RANGE_M
        assert np.std(kept - RANGE_M) == pytest.approx(sigma, rel=0.1)
        assert 1.0 - kept.size / obs.size == pytest.approx(rec["dropout"], abs=0.02)
        draws.append((rec["std_per_m"], rec["dropout"]))
    s1 = np.array([d[0] for d in draws])
    assert np.unique(s1).size == 12  # one draw per episode
    lo, hi = data["noise_std_per_m_ci"]
    assert abs(np.mean(s1) - data["noise_std_per_m"]) < 5.0 * (hi - lo)


def test_same_seed_same_noise_and_config_round_trip(sensors_yaml: Path, tmp_path: Path) -> None:
    config = {
        "format": "sim2real.randomizers/1",
        "randomizers": [{"type": "LidarNoise", "sysid": sensors_yaml.name, "spread": 2.0}],
    }
    (sensors_yaml.parent / "stack.yaml").write_text(yaml.safe_dump(config))
    a = from_config(Scan(), sensors_yaml.parent / "stack.yaml")
    b = from_config(Scan(), to_config(a), base_dir=sensors_yaml.parent)
    for seed in (3, 4):
        oa, ia = a.reset(seed=seed)
        ob, ib = b.reset(seed=seed)
        np.testing.assert_array_equal(oa, ob)
        assert ia["randomization"] == ib["randomization"]
    assert not np.array_equal(a.reset(seed=3)[0], a.reset(seed=4)[0])


def test_unidentified_noise_is_refused(sensors_yaml: Path, tmp_path: Path) -> None:
    data = yaml.safe_load(sensors_yaml.read_text())
    data["noise_std_per_m"] = None
    bad = tmp_path / "bad.yaml"
    bad.write_text(yaml.safe_dump(data))
    with pytest.raises(RandomizerConfigError, match="has no identified 'noise_std_per_m'"):
        LidarNoise.from_sysid(bad, env=Scan())


class ScanClock(gym.Env[Any, Any]):
    """The scan holds the step number, so a delay shows as an older step."""

    observation_space = gym.spaces.Dict({"scan": gym.spaces.Box(0.0, 1e6, (4,), np.float32)})
    action_space = gym.spaces.Discrete(1)

    def __init__(self) -> None:
        self.t = 0

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> Any:
        super().reset(seed=seed)
        self.t = 0
        return {"scan": np.zeros(4, np.float32)}, {}

    def step(self, action: Any) -> Any:
        self.t += 1
        return {"scan": np.full(4, self.t, np.float32)}, 0.0, False, False, {}


def test_scan_latency_from_the_identified_offset(tmp_path: Path) -> None:
    data = {
        "format": "sim2real.sysid.sensors/1",
        "time_offset_s": -0.2,
        "time_offset_ci": [-0.26, -0.14],
    }
    path = tmp_path / "sensors.yaml"
    path.write_text(yaml.safe_dump(data))
    env = OdometryDelay.from_sysid(path, env=ScanClock(), key="scan", dt_s=0.02)
    delays = set()
    for seed in range(30):
        _, info = env.reset(seed=seed)
        steps = info["randomization"]["OdometryDelay[scan]"]["delay_steps"]
        assert 7 <= steps <= 13  # 0.14-0.26 s at 20 ms steps
        for _ in range(steps + 2):
            obs = env.step(0)[0]
        assert obs["scan"][0] == 2  # steps + 2 taken, the scan shows step 2
        delays.add(steps)
    assert len(delays) > 3
    data["time_offset_ci"] = [None, None]
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(RandomizerConfigError, match="no identified 'time_offset_s'"):
        OdometryDelay.from_sysid(path, env=ScanClock(), key="scan", dt_s=0.02)
