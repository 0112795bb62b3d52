"""The robot back-ends of the envs: the reduced drive model, the pybullet robot or a plant.

They take a :class:`robots.spec.RobotSpec` and expose the same small interface: ``reset``,
``new_session``, ``step(cmd_v, cmd_w, duration_s) -> (v, w)``, ``pose`` (x, y, yaw),
``velocity`` (v, w) and the drive-parameter protocol. ``"reduced"`` integrates the pose
kinematically from the drive model's velocity (exact circular arcs over sub-steps of at most
``substep_s``); ``"pybullet"`` steps the rigid-body robot of :mod:`robots` and reads its pose;
``"plant"`` drives a foreign plant (:mod:`sim2real.plants.closed_loop`), a base that is not
the project's drive model, and reports the base's odometry as its velocity.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Any, Protocol

import numpy as np

from robots.params import DriveParams
from robots.reduced import ReducedDrive
from sim2real.errors import Sim2RealValueError
from sim2real.plants.closed_loop import PlantSessions, PlantStepper, as_plant_sessions
from sim2real.plants.diff_drive import PlantParams

__all__ = [
    "DYNAMICS",
    "PlantBackend",
    "RobotBackend",
    "check_env_arguments",
    "checked_action",
    "footprint_radius_m",
    "make_backend",
]

#: The dynamics back-ends an env accepts.
DYNAMICS = ("reduced", "pybullet", "plant")


def checked_action(action: Any, space: Any) -> np.ndarray:
    """An env's action (v m/s, w rad/s) as two floats clipped to its Box ``space``; refused in
    one sentence unless it is two finite numbers."""
    a = np.asarray(action, dtype=np.float64).reshape(-1)
    if a.shape != (2,) or not np.all(np.isfinite(a)):
        raise Sim2RealValueError(
            f"action must be 2 finite numbers (v [m/s], w [rad/s]), got {action!r}"
        )
    return np.asarray(np.clip(a, space.low, space.high))


def check_env_arguments(
    *,
    dynamics: str,
    control_dt: float,
    max_episode_steps: int,
    drive_params: DriveParams | None,
    pybullet_body: str = "full rigid-body robot",
    choices: tuple[str, ...] = DYNAMICS,
) -> None:
    """Refuse an env constructor's common arguments that are out of range, in one sentence.

    Shared by the navigation envs, CarCrossing-v0 and Race-v0; ``pybullet_body`` names what the
    pybullet back-end simulates, ``choices`` the back-ends the env has.
    """
    if dynamics not in choices:
        plant = ", or 'plant' (a foreign base to evaluate on)" if "plant" in choices else ""
        raise Sim2RealValueError(
            f"dynamics (--dynamics) must be one of {', '.join(choices)}, got {dynamics!r}; "
            f"use 'reduced' (fast) or 'pybullet' ({pybullet_body}){plant}"
        )
    if not (isinstance(control_dt, int | float) and math.isfinite(control_dt) and control_dt > 0):
        raise Sim2RealValueError(
            f"control_dt must be a finite number of seconds > 0, got {control_dt!r}; "
            "the default is 0.1"
        )
    if not (isinstance(max_episode_steps, int) and max_episode_steps >= 1):
        raise Sim2RealValueError(
            f"max_episode_steps must be an integer >= 1, got {max_episode_steps!r}"
        )
    if drive_params is not None and not isinstance(drive_params, DriveParams):
        raise Sim2RealValueError(
            f"drive_params must be a robots.DriveParams, got {type(drive_params).__name__}"
        )


def footprint_radius_m(spec: Any) -> float:
    """Radius of the disc about the base origin that contains the base body and the wheels, m."""
    body = spec.body
    if body.shape == "cylinder":
        r_body = math.hypot(body.xyz_m[0], body.xyz_m[1]) + 0.5 * body.size_m[0]
    else:
        hx, hy = 0.5 * body.size_m[0], 0.5 * body.size_m[1]
        r_body = max(
            math.hypot(body.xyz_m[0] + sx * hx, body.xyz_m[1] + sy * hy)
            for sx in (-1, 1)
            for sy in (-1, 1)
        )
    w = spec.wheels
    r_wheel = math.hypot(w.radius_m, 0.5 * (w.separation_m + w.width_m))
    return max(r_body, r_wheel)


def arc_step(
    x: float, y: float, yaw: float, v: float, w: float, h: float
) -> tuple[float, float, float]:
    """Pose after ``h`` seconds at constant ``v`` (m/s) and ``w`` (rad/s): the exact arc.

    The vector envs compile this same function (``sim2real.envs._vecnav``) and the car steps
    its rear axle with it (``sim2real.envs._car``), so one source integrates every reduced
    robot's pose.
    """
    dth = w * h
    if abs(dth) < 1e-9:
        x += v * h * math.cos(yaw + 0.5 * dth)
        y += v * h * math.sin(yaw + 0.5 * dth)
    else:
        x += v / w * (math.sin(yaw + dth) - math.sin(yaw))
        y -= v / w * (math.cos(yaw + dth) - math.cos(yaw))
    return x, y, math.atan2(math.sin(yaw + dth), math.cos(yaw + dth))


class RobotBackend(Protocol):
    """What the envs need from a robot back-end."""

    @property
    def pose(self) -> tuple[float, float, float]:
        """(x [m], y [m], yaw [rad]) in the world frame."""
        ...

    @property
    def velocity(self) -> tuple[float, float]:
        """Measured (v [m/s], w [rad/s]) in the base frame."""
        ...

    def reset(self, x: float, y: float, yaw: float) -> None:
        """Place the robot at rest."""

    def new_session(self, rng: Any) -> None:
        """Draw the next episode's robot from ``rng`` where the back-end has sessions."""

    def step(self, cmd_v: float, cmd_w: float, duration_s: float) -> tuple[float, float]:
        """Apply the command for ``duration_s``; return the measured (v, w)."""
        ...

    def get_drive_params(self) -> DriveParams:
        """The drive parameters in use."""
        ...

    def set_drive_params(self, params: DriveParams) -> None:
        """Replace the drive parameters (takes effect at the next step)."""

    def close(self) -> None:
        """Release resources."""


class _ArcPose:
    """The pose of a base that moves along exact arcs (:func:`arc_step`) at the mean of each
    sub-step's first and last body velocity."""

    _pose: tuple[float, float, float] = (0.0, 0.0, 0.0)

    @property
    def pose(self) -> tuple[float, float, float]:
        return self._pose

    def _place(self, x: float, y: float, yaw: float) -> None:
        self._pose = (float(x), float(y), float(yaw))

    def _move(self, v0: float, w0: float, ends: Iterable[tuple[float, float]], h: float) -> None:
        """Advance the pose over sub-steps of ``h`` s from velocity (v0, w0), one per item of
        ``ends`` (each sub-step's last velocity)."""
        x, y, yaw = self._pose
        for v1, w1 in ends:
            x, y, yaw = arc_step(x, y, yaw, 0.5 * (v0 + v1), 0.5 * (w0 + w1), h)
            v0, w0 = v1, w1
        self._pose = (x, y, yaw)


class ReducedBackend(_ArcPose):
    """Reduced drive model (numba) + kinematic pose integration."""

    def __init__(self, spec: Any, params: DriveParams, *, substep_s: float = 0.02) -> None:
        self._drive = ReducedDrive(params, spec.geometry)
        self._substep_s = substep_s

    @property
    def velocity(self) -> tuple[float, float]:
        return self._drive.velocity

    def reset(self, x: float, y: float, yaw: float) -> None:
        self._drive.reset()
        self._place(x, y, yaw)

    def new_session(self, rng: Any) -> None:
        pass

    def step(self, cmd_v: float, cmd_w: float, duration_s: float) -> tuple[float, float]:
        n = max(1, math.ceil(duration_s / self._substep_s - 1e-9))
        h = duration_s / n
        v0, w0 = self._drive.velocity
        self._move(v0, w0, (self._drive.step(cmd_v, cmd_w, h) for _ in range(n)), h)
        return self._drive.velocity

    def get_drive_params(self) -> DriveParams:
        return self._drive.params

    def set_drive_params(self, params: DriveParams) -> None:
        self._drive.params = params

    def close(self) -> None:
        pass


class PybulletBackend:
    """The rigid-body pybullet robot of :mod:`robots` (``robots.PybulletRobot``)."""

    def __init__(
        self, spec: Any, params: DriveParams, *, client: int, physics_hz: float = 240.0
    ) -> None:
        from robots.pybullet_robot import PybulletRobot

        self._make = PybulletRobot
        self._spec, self._client, self._physics_hz = spec, client, physics_hz
        self._robot = PybulletRobot(
            spec, client=client, params=params, physics_hz=physics_hz, start_pose=(0.0, 0.0, 0.0)
        )

    @property
    def body_id(self) -> int:
        """pybullet body id of the robot."""
        return int(self._robot.body_id)

    @property
    def pose(self) -> tuple[float, float, float]:
        x, y, yaw = self._robot.pose
        return float(x), float(y), float(yaw)

    @property
    def velocity(self) -> tuple[float, float]:
        v, w = self._robot.velocity
        return float(v), float(w)

    def reset(self, x: float, y: float, yaw: float) -> None:
        """Load a new robot body at (x, y, yaw): the env resets the whole simulation first,
        so that a seeded episode replays exactly, whatever ran before (pybullet keeps contact
        points and their warm-start impulses otherwise; tests/sim2real/envs/
        test_envs_reset_replays.py)."""
        self._robot = self._make(
            self._spec,
            client=self._client,
            params=self._robot.get_drive_params(),
            physics_hz=self._physics_hz,
            start_pose=(x, y, yaw),
        )

    def new_session(self, rng: Any) -> None:
        pass

    def step(self, cmd_v: float, cmd_w: float, duration_s: float) -> tuple[float, float]:
        v, w = self._robot.step(cmd_v, cmd_w, duration_s)
        return float(v), float(w)

    def get_drive_params(self) -> DriveParams:
        params: DriveParams = self._robot.get_drive_params()
        return params

    def set_drive_params(self, params: DriveParams) -> None:
        self._robot.set_drive_params(params)

    def close(self) -> None:
        pass


class PlantBackend(_ArcPose):
    """A foreign plant session per episode (:class:`~sim2real.plants.closed_loop.PlantStepper`).

    The pose is integrated from the plant's true body velocity (exact arcs over its sub-steps,
    as :class:`ReducedBackend`); ``velocity`` is the base's odometry. The drive-parameter
    protocol reads the spec's parameters and refuses changes: the plant's motion comes from its
    own physics.
    """

    def __init__(self, spec: Any, params: DriveParams, sessions: PlantSessions) -> None:
        self._params = params
        self.sessions = sessions
        self._stepper = PlantStepper(sessions.base, np.random.default_rng(0))

    @property
    def session(self) -> PlantParams:
        """The plant of the current episode."""
        return self._stepper.params

    @property
    def velocity(self) -> tuple[float, float]:
        return self._stepper.odometry

    def new_session(self, rng: Any) -> None:
        """Draw the session's plant, then seed its noise (latency, gyro) from ``rng``."""
        params = self.sessions.draw(rng)
        self._stepper = PlantStepper(params, np.random.default_rng(int(rng.integers(2**63))))

    def reset(self, x: float, y: float, yaw: float) -> None:
        self._stepper.reset()
        self._place(x, y, yaw)

    def step(self, cmd_v: float, cmd_w: float, duration_s: float) -> tuple[float, float]:
        v0, w0 = self._stepper.true_velocity
        t, v, w = self._stepper.step(cmd_v, cmd_w, duration_s)
        self._move(v0, w0, zip(v.tolist(), w.tolist(), strict=True), duration_s / t.size)
        return self._stepper.odometry

    def get_drive_params(self) -> DriveParams:
        return self._params

    def set_drive_params(self, params: DriveParams) -> None:
        raise Sim2RealValueError(
            "set_drive_params does not apply to dynamics='plant': the plant's motion comes from "
            "its own physics; choose its sessions with plant_sessions=, or train with "
            "dynamics='reduced'"
        )

    def close(self) -> None:
        pass


def make_backend(
    dynamics: str,
    spec: Any,
    params: DriveParams,
    *,
    client: int | None = None,
    plant_sessions: Any = None,
) -> RobotBackend:
    """The back-end called ``dynamics`` (one of :data:`DYNAMICS`).

    ``plant_sessions`` (``dynamics="plant"`` only): a
    :class:`~sim2real.plants.closed_loop.PlantSessions`, one fixed
    :class:`~sim2real.plants.diff_drive.PlantParams`, or ``None`` for the robot's plant with
    the default session variation.
    """
    if plant_sessions is not None and dynamics != "plant":
        raise Sim2RealValueError(
            f"plant_sessions drive dynamics='plant' only, got dynamics={dynamics!r}; "
            "pass dynamics='plant' or leave plant_sessions out"
        )
    if dynamics == "plant":
        return PlantBackend(spec, params, as_plant_sessions(plant_sessions, spec.name))
    if dynamics == "reduced":
        return ReducedBackend(spec, params)
    if dynamics == "pybullet":
        if client is None:
            raise Sim2RealValueError("dynamics='pybullet' needs a pybullet client")
        return PybulletBackend(spec, params, client=client)
    raise Sim2RealValueError(
        f"dynamics must be one of {', '.join(DYNAMICS)}, got {dynamics!r}; "
        "use 'reduced' (fast) or 'pybullet' (full rigid-body robot)"
    )
