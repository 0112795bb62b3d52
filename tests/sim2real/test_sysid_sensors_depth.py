"""`sysid sensors` on depth images: real ROS 2 MCAP files with CDR Image messages of the
project's depth camera (`sim2real.envs.depth.render_depth`) with known noise."""

from __future__ import annotations

import contextlib
import io
import math
import shutil
from collections.abc import Callable
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml

from randomizers import DepthNoise, from_config
from randomizers.errors import RandomizerConfigError
from sim2real.cli import main
from sim2real.envs.depth import DepthScene, render_depth, rpy_matrix
from sim2real.logs import read_depth
from sysid.sensors import PoseArrays, ScanArrays, load_sensor
from tests.sim2real.test_cli_bad_input import Run, assert_bad_input, cli
from tests.sim2real.test_sysid_sensors_cli import T0_NS, _messages, mounted_spec, write_mcap
from tests.sim2real.test_sysid_sensors_cli import _write as write_scans
from tests.sysid.sensor_truth import draw_truth, synthetic_recording

STD0_M, STD2_PER_M2, INVALID = 0.001, 0.0025, 0.03  # sigma(d) = 1 mm + 2.5 mm/m^2 d^2
WIDTH, HEIGHT = 64, 48


def _room() -> DepthScene:
    walls = [(0.0, 2.5, 7.0, 0.1, 0.0, 2.0), (0.0, -2.5, 7.0, 0.1, 0.0, 2.0)]
    walls += [(3.5, 0.0, 0.1, 5.0, 0.0, 2.0), (-3.5, 0.0, 0.1, 5.0, 0.0, 2.0)]
    boxes = [(2.0, 1.2, 0.8, 0.5, 0.3, 0.6), (-2.2, -1.0, 0.6, 0.6, 0.0, 0.9)]
    pillars = [(1.5, -1.5, 0.2, 1.5), (-1.0, 1.6, 0.15, 1.5), (-2.5, 1.0, 0.25, 1.5)]
    return DepthScene.build(cylinders=pillars, boxes=walls + boxes)


def _frames(odom: PoseArrays, t_s: np.ndarray, seed: int) -> np.ndarray:
    """Noisy depth frames (m, no return NaN) from a camera 0.3 m up on the base."""
    rng = np.random.default_rng(seed)
    scene = _room()
    x, y, yaw = (np.interp(t_s, odom.t_s, v) for v in (odom.x_m, odom.y_m, np.unwrap(odom.yaw_rad)))
    out = np.empty((t_s.size, HEIGHT, WIDTH))
    for k in range(t_s.size):
        true = render_depth(
            scene,
            eye=np.array([x[k], y[k], 0.3]),
            rotation=rpy_matrix(0.0, 0.15, yaw[k]),
            width=WIDTH,
            height=HEIGHT,
            hfov_deg=60.0,
            near_m=0.05,
            far_m=8.0,
        )
        noisy = true + rng.standard_normal(true.shape) * (STD0_M + STD2_PER_M2 * true**2)
        noisy[(rng.random(true.shape) < INVALID) | (true >= 8.0)] = np.nan
        out[k] = noisy
    return out


def _write(
    path: Path,
    scans: ScanArrays,
    odom: PoseArrays,
    frames: np.ndarray,
    encoding: str,
    halve_at: int = -1,
) -> Path:
    """Scans, odometry and depth images as a ROS 2 MCAP file (rosbag2 folder); the image
    ``halve_at`` has half the rows."""
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    T = store.types
    msgs = _messages(store, scans, odom, ros1=False)
    for k, t in enumerate(scans.t_s):
        img = frames[k][: HEIGHT // 2] if k == halve_at else frames[k]
        if encoding == "16UC1":
            data = np.nan_to_num(np.rint(img * 1000.0), nan=0.0).astype("<u2")
        else:
            data = img.astype("<f4")
        t_ns = T0_NS + round(float(t) * 1e9)
        stamp = T["builtin_interfaces/msg/Time"](sec=t_ns // 10**9, nanosec=t_ns % 10**9)
        msg = T["sensor_msgs/msg/Image"](
            header=T["std_msgs/msg/Header"](stamp=stamp, frame_id="camera_depth"),
            height=img.shape[0],
            width=WIDTH,
            encoding=encoding,
            is_bigendian=0,
            step=WIDTH * data.itemsize,
            data=data.reshape(-1).view(np.uint8),
        )
        msgs.append((t_ns, "/camera/depth/image_raw", "sensor_msgs/msg/Image", msg))
    return write_mcap(path, store, msgs)


@pytest.fixture(scope="module")
def recording() -> tuple[ScanArrays, PoseArrays, np.ndarray]:
    scans, odom = synthetic_recording(draw_truth(np.random.default_rng(5)), 5)
    return scans, odom, _frames(odom, scans.t_s, 5)


@pytest.fixture(scope="module")
def spec_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return mounted_spec(tmp_path_factory.mktemp("spec") / "base.yaml")


#: One ``sysid sensors`` run of the recording with its depth topic in an encoding: the log, the
#: sensor file, the report and the run.
Identified = tuple[Path, Path, Path, Run]


@pytest.fixture(scope="module")
def identified(
    tmp_path_factory: pytest.TempPathFactory,
    recording: tuple[ScanArrays, PoseArrays, np.ndarray],
    spec_file: Path,
) -> Callable[[str], Identified]:
    """``sysid sensors --report`` on the recording written in an encoding, run once per
    encoding for the tests that read it (read only: a test that writes copies first)."""
    runs: dict[str, Identified] = {}

    def run(encoding: str) -> Identified:
        if encoding not in runs:
            folder = tmp_path_factory.mktemp(f"depth_{encoding}")
            log = _write(folder / "r2", *recording, encoding)
            out, report = folder / "sensors.yaml", folder / "sensors.html"
            printed, errors = io.StringIO(), io.StringIO()
            argv = ["sysid", "sensors", log, "--robot", spec_file, "-o", out, "--report", report]
            with contextlib.redirect_stdout(printed), contextlib.redirect_stderr(errors):
                code = main([str(a) for a in argv])
            runs[encoding] = (
                log,
                out,
                report,
                Run(code=code, out=printed.getvalue(), err=errors.getvalue()),
            )
        return runs[encoding]

    return run


def _truth(d: float) -> float:
    return STD0_M + STD2_PER_M2 * d * d


@pytest.mark.parametrize("encoding", ["16UC1", "32FC1"])
def test_depth_noise_identified_from_a_depth_topic(
    recording: tuple[ScanArrays, PoseArrays, np.ndarray],
    identified: Callable[[str], Identified],
    encoding: str,
) -> None:
    log, out, report, run = identified(encoding)
    images = read_depth(log)
    assert images is not None and images.encoding == encoding
    assert images.depth_m.shape == (recording[0].t_s.size, WIDTH * HEIGHT)
    assert run.code == 0, run.err
    assert "depth camera /camera/depth/image_raw (64 x 48" in run.out
    assert "depth camera: invalid pixels, %" in report.read_text()
    depth = load_sensor(out).depth
    assert depth is not None and depth.still_frames >= 80
    for r, std in zip(depth.noise_range_m, depth.noise_std_m, strict=True):
        assert std == pytest.approx(_truth(r), rel=0.15), (r, std, _truth(r))
    mid = len(depth.noise_range_m) // 2
    assert (
        depth.noise_std_lo_m[mid] <= _truth(depth.noise_range_m[mid]) <= depth.noise_std_hi_m[mid]
    )
    assert depth.dropout == pytest.approx(INVALID, abs=0.015)
    assert depth.dropout_ci[0] <= INVALID <= depth.dropout_ci[1]


class _Cam(gym.Env[np.ndarray, np.int64]):
    observation_space = gym.spaces.Box(0.0, 8.0, (HEIGHT, WIDTH), np.float32)
    action_space = gym.spaces.Discrete(1)

    def reset(self, *, seed=None, options=None):  # type: ignore[no-untyped-def]
        super().reset(seed=seed)
        return np.full((HEIGHT, WIDTH), 3.0, np.float32), {}

    def step(self, action):  # type: ignore[no-untyped-def]
        return np.full((HEIGHT, WIDTH), 3.0, np.float32), 0.0, False, False, {}


def test_depth_noise_from_sysid_and_from_config(
    tmp_path: Path, identified: Callable[[str], Identified]
) -> None:
    _log, shared, _report, run = identified("32FC1")  # the 32FC1 identification test's run
    assert run.code == 0, run.err
    out = tmp_path / "sensors.yaml"
    shutil.copyfile(shared, out)
    depth = load_sensor(out).depth
    assert depth is not None
    env = DepthNoise.from_sysid(out, env=_Cam(), near_m=0.05, far_m=8.0)
    stds, invalid = [], []
    for episode in range(40):
        obs, _ = env.reset(seed=episode)
        valid = obs < 8.0
        invalid.append(1.0 - valid.mean())
        stds.append(float(np.std(obs[valid] - 3.0)))
    # the pixels at 3 m spread like the identified camera's, episode after episode
    assert np.median(stds) == pytest.approx(_truth(3.0), rel=0.15)
    assert np.mean(invalid) == pytest.approx(INVALID, abs=0.015)
    assert len({round(s, 6) for s in stds}) == 40  # each episode draws its own noise
    config = {
        "randomizers": [{"type": "DepthNoise", "sysid": out.name, "near_m": 0.05, "far_m": 8.0}]
    }
    (tmp_path / "dr.yaml").write_text(yaml.safe_dump(config))
    stacked = from_config(_Cam(), tmp_path / "dr.yaml")
    a, _ = stacked.reset(seed=3)
    b, _ = env.reset(seed=3)
    np.testing.assert_array_equal(a, b)


def test_a_sensor_file_without_depth_is_one_sentence(
    tmp_path: Path,
    recording: tuple[ScanArrays, PoseArrays, np.ndarray],
    spec_file: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    scans, odom, _ = recording
    log = write_scans(tmp_path / "r2", scans, odom, ros1=False)
    out = tmp_path / "s.yaml"
    assert cli(capsys, "sysid", "sensors", log, "--robot", spec_file, "-o", out).code == 0
    assert load_sensor(out).depth is None
    with pytest.raises(RandomizerConfigError, match="has no 'depth' section"):
        DepthNoise.from_sysid(out, env=_Cam(), near_m=0.05, far_m=8.0)
    run = cli(
        capsys,
        "sysid",
        "sensors",
        log,
        "--robot",
        spec_file,
        "-o",
        out,
        "--depth-topic",
        "/camera/depth",
    )
    assert_bad_input(run, "no sensor_msgs/msg/Image topic '/camera/depth'", "/scan")
    assert math.isfinite(load_sensor(out).noise_std_0_m)


def test_images_that_change_size_are_one_sentence(
    tmp_path: Path,
    recording: tuple[ScanArrays, PoseArrays, np.ndarray],
    spec_file: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    log = _write(tmp_path / "r2", *recording, "16UC1", halve_at=9)
    out = tmp_path / "s.yaml"
    run = cli(capsys, "sysid", "sensors", log, "--robot", spec_file, "-o", out)
    assert_bad_input(run, "changes its images", "64 x 48 16UC1, message 9 is 64 x 24")
    assert not out.exists()
