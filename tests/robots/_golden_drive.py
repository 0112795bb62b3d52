"""Golden traces of the drive chain (reduced model and pybullet robot), compared bit for bit.

The reduced model's traces were recorded before the drive-step kernel was shared (issue 16);
the pybullet robot's were re-recorded once since, when its axis friction moved from an external
force at the centre of mass to the wheels (same flat-ground motion to 1e-4 m/s, 7e-5 rad/s).

Regenerate (only after an intended change of the physics) with
``.venv/bin/python -m tests.robots._golden_drive``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from robots import PybulletRobot, ReducedDrive, load_spec, simulate
from robots.params import DriveParams
from robots.spec import RobotSpec

__all__ = ["CASES", "GOLDEN", "commands", "params_of", "record"]

GOLDEN = Path(__file__).resolve().parent / "golden" / "drive_golden.npz"

#: (robot, parameter overrides): the spec's chain; torque-saturated with smoother limits and
#: added mass; a long delay with a short command timeout.
CASES: dict[str, tuple[str, dict[str, float]]] = {
    "burger_spec": ("turtlebot3_burger", {}),
    "burger_saturated": (
        "turtlebot3_burger",
        {
            "wheel_torque_max_nm": 0.03,
            "accel_lim_v_mps2": 1.5,
            "accel_lim_w_radps2": 6.0,
            "added_mass_kg": 0.4,
            "delay_s": 0.05,
        },
    ),
    "tb2_delay_timeout": ("turtlebot2", {"delay_s": 0.2, "cmd_timeout_s": 0.35}),
}


def params_of(spec: RobotSpec, overrides: dict[str, float]) -> DriveParams:
    return spec.drive.replace(**overrides)


def commands(spec: RobotSpec, seconds: float = 3.0) -> dict[str, np.ndarray]:
    """10 Hz random steps (seeded) with a pause, 30 Hz output times."""
    rng = np.random.default_rng(7)
    n = round(seconds * 10)
    cmd_t = 0.1 * np.arange(n) + 0.013
    v = np.repeat(rng.uniform(-1.2, 1.2, n // 5 + 1), 5)[:n] * spec.max_v_mps
    w = np.repeat(rng.uniform(-1.2, 1.2, n // 5 + 1), 5)[:n] * spec.max_w_radps
    keep = (cmd_t < 1.2) | (cmd_t > 1.8)  # a gap: the timeout acts
    t_out = np.arange(0.0, seconds, 1.0 / 30.0)
    return {"cmd_t_s": cmd_t[keep], "cmd_v": v[keep], "cmd_w": w[keep], "t_out_s": t_out}


def record() -> dict[str, np.ndarray]:
    """Every golden array, by ``<case>/<what>``."""
    out: dict[str, np.ndarray] = {}
    for case, (robot, overrides) in CASES.items():
        spec = load_spec(robot)
        params = params_of(spec, overrides)
        cmd = commands(spec)
        red = simulate(params, spec.geometry, **cmd, v0=0.05, w0=-0.1)
        out[f"{case}/simulate"] = np.stack([red.v, red.w])
        drive = ReducedDrive(params, spec.geometry)
        steps = [
            drive.step(float(a), float(b), 0.1)
            for a, b in zip(cmd["cmd_v"], cmd["cmd_w"], strict=True)
        ]
        out[f"{case}/reduced_step"] = np.array(steps)
        with PybulletRobot(spec, params=params) as robot:
            rep = robot.replay(**cmd, v0=0.05, w0=-0.1)
            out[f"{case}/pybullet_replay"] = np.stack(
                [rep.v, rep.w, rep.odom_v, rep.odom_w, rep.x_m, rep.y_m, rep.yaw_rad]
            )
            robot.reset()
            rows = []
            for a, b in zip(cmd["cmd_v"][:15], cmd["cmd_w"][:15], strict=True):
                v, w = robot.step(float(a), float(b), 0.1)
                rows.append((v, w, *robot.wheel_torques, *robot.pose))
            out[f"{case}/pybullet_step"] = np.array(rows)
    return out


if __name__ == "__main__":
    GOLDEN.parent.mkdir(exist_ok=True)
    np.savez_compressed(GOLDEN, **record())
    print(f"wrote {GOLDEN}")
