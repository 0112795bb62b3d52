"""Helpers of the log I/O tests: synthetic velocity-log arrays (unique module name)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

T0_NS = 1_700_000_000_000_000_000


@dataclass(frozen=True)
class Arrays:
    """The arrays a synthetic log was written from."""

    cmd_t_ns: np.ndarray
    cmd_v: np.ndarray
    cmd_w: np.ndarray
    meas_t_ns: np.ndarray
    meas_v: np.ndarray
    meas_w: np.ndarray
    pose_x: np.ndarray
    pose_y: np.ndarray
    pose_yaw: np.ndarray

    def kwargs(self) -> dict[str, np.ndarray]:
        return dict(self.__dict__)


def make_arrays(n_cmd: int = 40, n_meas: int = 100, seed: int = 0) -> Arrays:
    """Commands at 10 Hz and odometry at 25 Hz with jittered stamps and random values."""
    rng = np.random.default_rng(seed)
    cmd_t = T0_NS + np.arange(n_cmd, dtype=np.int64) * 100_000_000 + 3
    meas_t = T0_NS + 1_234_567 + np.arange(n_meas, dtype=np.int64) * 40_000_000
    meas_t += rng.integers(0, 1000, n_meas)
    return Arrays(
        cmd_t_ns=cmd_t,
        cmd_v=rng.uniform(-0.3, 0.3, n_cmd),
        cmd_w=rng.uniform(-2, 2, n_cmd),
        meas_t_ns=meas_t,
        meas_v=rng.normal(0.1, 0.05, n_meas),
        meas_w=rng.normal(0.0, 0.5, n_meas),
        pose_x=rng.uniform(-5, 5, n_meas),
        pose_y=rng.uniform(-5, 5, n_meas),
        pose_yaw=rng.uniform(-3.0, 3.0, n_meas),
    )
