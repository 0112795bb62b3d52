"""Generator of the bundled synthetic sample logs in ``data/`` (private).

``python -m sim2real._samples data`` regenerates ``data/demo_train.mcap`` and
``data/demo_validate.mcap``: a TurtleBot3 Burger whose drive has *hidden*, non-default
parameters (:data:`HIDDEN_CHANGES`: a payload, friction, a 0.15 s command delay and
acceleration limits) driven by two different command sequences, simulated with the project's
pybullet robot and recorded the way the real robot's firmware and ``ros2 bag`` would:

- commands (``/cmd_vel``, ``geometry_msgs/msg/Twist``) at 10 Hz, as a teleop or nav stack
  sends them; 1 % of them missing from the recording (recorder drops; the robot got them);
- odometry (``/odom``, ``nav_msgs/msg/Odometry``) at 30 Hz, the TB3 firmware rate ([FW-B] in
  ``shared/robot-specs.md``): forward speed from quantised wheel encoders (4096 ticks/rev,
  TICK2RAD 0.001533981 rad, [FW-W]) differenced over each period plus small slip noise; yaw
  rate from the gyro (TB3 odometry takes w from the IMU, [FW-W]/[T3P]) with white noise and a
  small bias; header stamps with 1 ms jitter; 2 % of the messages dropped.

Everything random comes from one seeded :class:`numpy.random.Generator` per log, so the files
are byte-for-byte reproducible for a given engine and library version.

Example
-------
>>> from sim2real._samples import build_sample  # doctest: +SKIP
>>> s = build_sample("train")  # doctest: +SKIP
>>> round(s.duration_s)  # doctest: +SKIP
150
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from robots.params import DriveParams
from sim2real.logs import integrate_pose

__all__ = [
    "CMD_RATE_HZ",
    "HIDDEN_CHANGES",
    "ODOM_RATE_HZ",
    "ROBOT",
    "SAMPLE_FILES",
    "Sample",
    "build_sample",
    "hidden_params",
    "main",
    "write_samples",
]

FloatArray = NDArray[np.float64]

#: The robot the sample logs are for.
ROBOT = "turtlebot3_burger"
#: Command rate of the samples, Hz (a teleop / navigation stack's usual 10 Hz).
CMD_RATE_HZ = 10.0
#: Odometry rate, Hz (TB3 firmware publishes odometry at 30 Hz).
ODOM_RATE_HZ = 30.0
#: Encoder resolution of the TB3's Dynamixel XL430: 4096 ticks per wheel revolution.
TICK_RAD = 2.0 * math.pi / 4096.0
#: File name and seed of each sample log.
SAMPLE_FILES = {"train": ("demo_train.mcap", 11), "validate": ("demo_validate.mcap", 22)}

#: The hidden drive parameters, as changes to the spec defaults: a 0.45 kg payload (a small
#: laptop/battery pack), its yaw inertia, Coulomb and viscous friction, a 0.15 s command delay
#: (the order of the ~0.11-0.17 s measured on the real TB3 log in shared/realdata) and
#: velocity-smoother acceleration limits.
HIDDEN_CHANGES: dict[str, float] = {
    "delay_s": 0.15,
    "added_mass_kg": 0.45,
    "added_yaw_inertia_kgm2": 0.0015,
    "coulomb_v_fwd_n": 0.6,
    "coulomb_v_bwd_n": 0.8,
    "coulomb_w_nm": 0.02,
    "viscous_v_ns_per_m": 1.0,
    "viscous_w_nms_per_rad": 0.01,
    "accel_lim_v_mps2": 0.6,
    "accel_lim_w_radps2": 4.0,
}

_ODOM_DROP = 0.02
_CMD_DROP = 0.01
_STAMP_JITTER_S = 0.001
_V_SLIP_NOISE_MPS = 0.002
_GYRO_NOISE_RADPS = 0.012
_GYRO_BIAS_RADPS = 0.003
_T0_NS = 1_700_000_000_000_000_000  # 2023-11-14T22:13:20Z, an arbitrary epoch start


def hidden_params(defaults: DriveParams) -> DriveParams:
    """The sample robot's true drive parameters: ``defaults`` with :data:`HIDDEN_CHANGES`."""
    return defaults.replace(**HIDDEN_CHANGES)


# --- command sequences (10 Hz, piecewise) ------------------------------------------------------


def _hold(out: list[tuple[float, float]], v: float, w: float, seconds: float) -> None:
    out.extend([(v, w)] * max(1, round(seconds * CMD_RATE_HZ)))


def _ramp(out: list[tuple[float, float]], v0: float, v1: float, w: float, seconds: float) -> None:
    n = max(2, round(seconds * CMD_RATE_HZ))
    out.extend((float(v), w) for v in np.linspace(v0, v1, n))


def _train_commands(rng: np.random.Generator, duration_s: float) -> list[tuple[float, float]]:
    """Steps in v and w, arcs (some saturating a wheel), ramps, reversals and pauses."""
    out: list[tuple[float, float]] = []
    _hold(out, 0.0, 0.0, 2.0)
    kinds = ("step_v", "step_w", "arc", "ramp", "reverse")
    while len(out) < duration_s * CMD_RATE_HZ:
        kind = kinds[int(rng.integers(len(kinds)))]
        sign = 1.0 if rng.random() < 0.6 else -1.0
        if kind == "step_v":
            _hold(out, sign * rng.uniform(0.05, 0.22), 0.0, rng.uniform(2.5, 4.0))
        elif kind == "step_w":
            _hold(out, 0.0, sign * rng.uniform(0.4, 2.2), rng.uniform(2.0, 3.0))
        elif kind == "arc":
            _hold(out, rng.uniform(0.08, 0.2), sign * rng.uniform(0.3, 1.8), rng.uniform(2.5, 3.5))
        elif kind == "ramp":
            top = rng.uniform(0.12, 0.22)
            _ramp(out, 0.0, top, 0.0, rng.uniform(2.0, 3.0))
            _ramp(out, top, 0.0, 0.0, rng.uniform(2.0, 3.0))
        else:
            _hold(out, 0.15, 0.0, 2.5)
            _hold(out, -0.15, 0.0, 2.5)
        _hold(out, 0.0, 0.0, rng.uniform(0.8, 1.6))
    return out


def _validate_commands(rng: np.random.Generator, duration_s: float) -> list[tuple[float, float]]:
    """Go-to-goal legs (turn with decaying w, then drive with heading corrections) and teleop."""
    out: list[tuple[float, float]] = []
    _hold(out, 0.0, 0.0, 2.0)
    while len(out) < duration_s * CMD_RATE_HZ:
        if rng.random() < 0.55:
            heading = rng.uniform(-2.5, 2.5)
            while abs(heading) > 0.05:  # proportional turn, like a go-to-goal controller
                w = float(np.clip(1.2 * heading, -1.5, 1.5))
                out.append((0.0, w))
                heading -= w * 0.7 / CMD_RATE_HZ
            n = round(rng.uniform(3.0, 6.0) * CMD_RATE_HZ)
            phase = rng.uniform(0, 2 * math.pi)
            speed = rng.uniform(0.1, 0.22)
            for k in range(n):
                out.append((speed, 0.15 * math.sin(phase + 0.9 * k / CMD_RATE_HZ)))
        else:  # teleop keys: a few held combinations
            for _ in range(int(rng.integers(2, 5))):
                v = float(rng.choice([0.0, 0.1, 0.2, -0.1]))
                w = float(rng.choice([0.0, 0.0, 0.8, -0.8, 1.6]))
                _hold(out, v, w, rng.uniform(1.2, 2.5))
        _hold(out, 0.0, 0.0, rng.uniform(1.0, 2.0))
    return out


_SEQUENCES: dict[str, tuple[Callable[..., list[tuple[float, float]]], float]] = {
    "train": (_train_commands, 150.0),
    "validate": (_validate_commands, 120.0),
}


# --- simulation and the odometry model ---------------------------------------------------------


@dataclass(frozen=True, kw_only=True)
class Sample:
    """One synthetic log as arrays (what :func:`write_samples` records).

    Attributes
    ----------
    kind : str
        ``"train"`` or ``"validate"``.
    engine : str
        Simulator that produced the true motion (``"pybullet"`` or ``"reduced"``).
    params : DriveParams
        The hidden drive parameters.
    cmd_t_ns, cmd_v, cmd_w : ndarray
        Recorded commands (ns, m/s, rad/s).
    meas_t_ns, meas_v, meas_w : ndarray
        Recorded odometry header stamps (ns) and velocities (m/s, rad/s).
    meas_log_t_ns : ndarray
        When the recorder received each odometry message (stamp + 2-12 ms transport), ns.
    pose_x, pose_y, pose_yaw : ndarray
        Odometry pose (m, m, rad) integrated from the measured velocities.
    true_v, true_w : ndarray
        Noise-free base velocity at each recorded odometry sample.
    """

    kind: str
    engine: str
    params: DriveParams
    meas_log_t_ns: NDArray[np.int64]
    cmd_t_ns: NDArray[np.int64]
    cmd_v: FloatArray
    cmd_w: FloatArray
    meas_t_ns: NDArray[np.int64]
    meas_v: FloatArray
    meas_w: FloatArray
    pose_x: FloatArray
    pose_y: FloatArray
    pose_yaw: FloatArray
    true_v: FloatArray
    true_w: FloatArray

    @property
    def duration_s(self) -> float:
        """Span of the odometry stamps, s."""
        return float(self.meas_t_ns[-1] - self.meas_t_ns[0]) / 1e9


def _make_stepper(engine: str, params: DriveParams) -> Callable[[float, float, float], tuple]:  # type: ignore[type-arg]
    from robots.spec import load_spec

    spec = load_spec(ROBOT)
    if engine == "pybullet":
        from robots.pybullet_robot import PybulletRobot

        robot = PybulletRobot(spec, params=params, physics_hz=240.0)
        robot.reset()
        step: Callable[[float, float, float], tuple] = robot.step  # type: ignore[type-arg]
        return step
    from robots.reduced import ReducedDrive

    drive = ReducedDrive(params, spec.geometry)
    return drive.step


def _simulate_true(
    commands: list[tuple[float, float]], params: DriveParams, engine: str
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """True base (v, w) on the odometry grid; commands change every third odometry tick."""
    per_cmd = round(ODOM_RATE_HZ / CMD_RATE_HZ)
    dt = 1.0 / ODOM_RATE_HZ
    step = _make_stepper(engine, params)
    n = len(commands) * per_cmd
    v = np.empty(n + 1)
    w = np.empty(n + 1)
    v[0] = w[0] = 0.0
    k = 0
    for cv, cw in commands:
        for _ in range(per_cmd):
            k += 1
            v[k], w[k] = step(cv, cw, dt)
    t: FloatArray = dt * np.arange(n + 1, dtype=np.float64)
    return t, v, w


def _odometry(
    t: FloatArray, v: FloatArray, w: FloatArray, rng: np.random.Generator, r: float, sep: float
) -> tuple[FloatArray, FloatArray]:
    """Encoder-based v (quantised ticks differenced per period) and gyro-based w."""
    dt = np.diff(t)
    wheel_r = (v + 0.5 * sep * w) / r
    wheel_l = (v - 0.5 * sep * w) / r
    ang_r = np.concatenate(([0.0], np.cumsum(0.5 * (wheel_r[1:] + wheel_r[:-1]) * dt)))
    ang_l = np.concatenate(([0.0], np.cumsum(0.5 * (wheel_l[1:] + wheel_l[:-1]) * dt)))
    ticks_r = np.floor(ang_r / TICK_RAD)
    ticks_l = np.floor(ang_l / TICK_RAD)
    meas_v = np.empty_like(v)
    meas_v[0] = 0.0
    meas_v[1:] = 0.5 * r * TICK_RAD * (np.diff(ticks_r) + np.diff(ticks_l)) / dt
    meas_v += rng.normal(0.0, _V_SLIP_NOISE_MPS, v.size)
    meas_w = w + _GYRO_BIAS_RADPS + rng.normal(0.0, _GYRO_NOISE_RADPS, w.size)
    return meas_v, meas_w


def default_engine() -> str:
    """``"pybullet"`` when the pybullet robot is available, else ``"reduced"``."""
    try:
        from robots.pybullet_robot import PybulletRobot  # noqa: F401
    except ImportError:
        return "reduced"
    return "pybullet"


def build_sample(kind: str, *, engine: str | None = None) -> Sample:
    """Simulate and record one sample log (``kind`` is ``"train"`` or ``"validate"``)."""
    from robots.spec import load_spec

    if kind not in SAMPLE_FILES:
        raise ValueError(f"sample kind must be one of {sorted(SAMPLE_FILES)}, got {kind!r}")
    engine = engine or default_engine()
    spec = load_spec(ROBOT)
    params = hidden_params(spec.drive)
    seed = SAMPLE_FILES[kind][1]
    rng = np.random.default_rng(seed)
    make, duration = _SEQUENCES[kind]
    commands = make(rng, duration)
    t, true_v, true_w = _simulate_true(commands, params, engine)
    geo = spec.geometry
    meas_v, meas_w = _odometry(t, true_v, true_w, rng, geo.wheel_radius_m, geo.wheel_separation_m)
    # the base dead-reckons its pose from the velocities it measures
    px, py, pyaw = integrate_pose(_T0_NS + np.rint(t * 1e9).astype(np.int64), meas_v, meas_w)
    keep = rng.random(t.size) >= _ODOM_DROP
    keep[0] = True
    jitter = rng.normal(0.0, _STAMP_JITTER_S, t.size).clip(-0.004, 0.004)
    meas_t_ns = _T0_NS + np.rint((t + jitter) * 1e9).astype(np.int64)
    cmd_t = np.arange(len(commands)) / CMD_RATE_HZ
    cmd = np.asarray(commands, dtype=np.float64)
    cmd_keep = rng.random(cmd_t.size) >= _CMD_DROP
    cmd_keep[0] = True
    latency_ns = np.rint(rng.uniform(0.002, 0.012, t.size) * 1e9).astype(np.int64)
    return Sample(
        kind=kind,
        engine=engine,
        params=params,
        meas_log_t_ns=(meas_t_ns + latency_ns)[keep],
        cmd_t_ns=_T0_NS + np.rint(cmd_t[cmd_keep] * 1e9).astype(np.int64),
        cmd_v=cmd[cmd_keep, 0],
        cmd_w=cmd[cmd_keep, 1],
        meas_t_ns=meas_t_ns[keep],
        meas_v=meas_v[keep],
        meas_w=meas_w[keep],
        pose_x=px[keep],
        pose_y=py[keep],
        pose_yaw=pyaw[keep],
        true_v=true_v[keep],
        true_w=true_w[keep],
    )


def write_samples(out_dir: str | Path, *, engine: str | None = None) -> list[Path]:
    """Build both sample logs and write them as MCAP into ``out_dir``; returns the paths."""
    from sim2real.logs import write_velocity_log

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for kind, (name, _seed) in SAMPLE_FILES.items():
        s = build_sample(kind, engine=engine)
        path = out / name
        write_velocity_log(
            path,
            cmd_t_ns=s.cmd_t_ns,
            cmd_v=s.cmd_v,
            cmd_w=s.cmd_w,
            meas_t_ns=s.meas_t_ns,
            meas_v=s.meas_v,
            meas_w=s.meas_w,
            pose_x=s.pose_x,
            pose_y=s.pose_y,
            pose_yaw=s.pose_yaw,
            meas_log_t_ns=s.meas_log_t_ns,
        )
        paths.append(path)
        print(f"wrote {path} ({s.engine}, {s.duration_s:.0f} s, {path.stat().st_size} bytes)")
    return paths


def main(argv: list[str] | None = None) -> int:
    """``python -m sim2real._samples OUT_DIR [--engine pybullet|reduced]``."""
    parser = argparse.ArgumentParser(prog="python -m sim2real._samples", description=__doc__)
    parser.add_argument("out_dir", help="folder to write the sample logs into (e.g. data)")
    parser.add_argument("--engine", choices=("pybullet", "reduced"), default=None)
    args = parser.parse_args(argv)
    write_samples(args.out_dir, engine=args.engine)
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
