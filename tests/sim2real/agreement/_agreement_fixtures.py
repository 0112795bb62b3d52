"""Helpers of the agreement tests: small real MCAP logs from a robot with known parameters."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import yaml

from robots.params import DriveParams
from robots.reduced import simulate
from robots.spec import load_spec
from sim2real.logs import write_velocity_log
from tests.randomization_block import distribution_around

ROBOT = "turtlebot3_burger"
T0_NS = 1_700_000_000_000_000_000
#: A Neato fitted on its ksoltan test drive and calibrated on its obstacle avoidance (real logs).
NEATO_FIT = "neato_ksoltan_testdrive_2018-09-18-20-17-54.mcap"
NEATO_CALIBRATE = "neato_ksoltan_obstacle_avoid_demo_2018-09-18-20-30-36.mcap"
HIDDEN = {"delay_s": 0.15, "added_mass_kg": 0.4, "accel_lim_v_mps2": 0.6, "coulomb_v_fwd_n": 0.4}


def spec():  # type: ignore[no-untyped-def]
    return load_spec(ROBOT)


def hidden_params() -> DriveParams:
    return spec().drive.replace(**HIDDEN)


def write_log(
    path: Path,
    *,
    params: DriveParams | None = None,
    duration_s: float = 30.0,
    seed: int = 0,
    noise_v: float = 0.003,
    noise_w: float = 0.02,
    idle_s: float = 2.0,
    axes: str = "vw",
) -> Path:
    """Steps in v and w at 10 Hz, odometry at 30 Hz from the reduced model plus noise.

    ``axes="w"`` spins in place (v commanded and measured 0 throughout, as encoder odometry
    reports a spin), ``axes="v"`` drives straight only.
    """
    s = spec()
    rng = np.random.default_rng(seed)
    n_hold = int(duration_s / 2.0)
    cmd_t = np.arange(0.0, duration_s, 0.1)
    cmd_v = np.repeat(rng.uniform(-0.2, 0.2, n_hold + 1), 20)[: cmd_t.size]
    cmd_w = np.repeat(rng.uniform(-1.5, 1.5, n_hold + 1), 20)[: cmd_t.size]
    cmd_v[cmd_t < idle_s] = 0.0
    cmd_w[cmd_t < idle_s] = 0.0
    for axis, cmd in (("v", cmd_v), ("w", cmd_w)):
        if axis not in axes:
            cmd[:] = 0.0
    meas_t = np.arange(0.0, duration_s, 1.0 / 30.0)
    true = simulate(
        params or hidden_params(), s.geometry,
        cmd_t_s=cmd_t, cmd_v=cmd_v, cmd_w=cmd_w, t_out_s=meas_t,
    )  # fmt: skip
    write_velocity_log(
        path,
        cmd_t_ns=T0_NS + np.rint(cmd_t * 1e9).astype(np.int64),
        cmd_v=cmd_v,
        cmd_w=cmd_w,
        meas_t_ns=T0_NS + np.rint(meas_t * 1e9).astype(np.int64),
        meas_v=(true.v + rng.normal(0.0, noise_v, meas_t.size)) * ("v" in axes),
        meas_w=(true.w + rng.normal(0.0, noise_w, meas_t.size)) * ("w" in axes),
    )
    return path


def write_params(
    path: Path,
    values: dict[str, float],
    *,
    robot: str = ROBOT,
    rel_std: float = 0.05,
    rel_band: float = 0.3,
) -> Path:
    """A params file in the sysid result format (every given value 'fitted' with a std).

    Its ``randomization`` block is centred on the spec defaults with ``values`` applied (prior
    covariance x ``rel_band**2``; noise as :func:`write_log` adds it).
    """
    base = load_spec(robot).drive.replace(**values)
    doc = {
        "format": "sim2real.sysid/1",
        "robot": robot,
        "tool_version": "test",
        "parameters": {
            k: {
                "value": float(v),
                "std": rel_std * abs(float(v)),
                "ci95": [float(v) * (1 - 2 * rel_std), float(v) * (1 + 2 * rel_std)],
                "status": "fitted",
            }
            for k, v in values.items()
        },
        "randomization": distribution_around(base, robot, rel=rel_band).to_dict(),
    }
    path.write_text(yaml.safe_dump(doc), encoding="utf-8")
    return path


def write_logs(root: Path, seeds: tuple[int, ...], *, duration_s: float = 20.0) -> tuple[Path, ...]:
    """One :func:`write_log` per seed, ``ROOT/log_<seed>.mcap`` (different commands each)."""
    return tuple(
        write_log(root / f"log_{seed}.mcap", duration_s=duration_s, seed=seed) for seed in seeds
    )
