r"""A small four-wheeled car with front-wheel Ackermann steering (Trararak et al.'s robot).

Geometry (Trararak et al., Sec. III-B): chassis 26 cm x 18 cm x 5 cm, wheels of radius 5 cm and
3 cm width; the front wheels steer, the rear wheels drive. Not printed, our choices: wheelbase
18 cm, track (wheel centre to wheel centre) 22 cm (the wheels clear the chassis), total mass 1.0 kg, steering limit 30
degrees, steering servo rate 3 rad/s.

Two back-ends with the same interface (``reset``, ``step(cmd_v, cmd_steer, duration_s)``,
``pose`` of the chassis centre, ``speed_mps``, ``steer_rad`` and the drive-parameter
protocol):

- :class:`ReducedCar`: the longitudinal axis is the identified drive chain of
  :class:`robots.reduced.ReducedDrive` (its v channel: transport delay, speed clamp, rate
  limit, wheel loop with torque saturation, friction, mass); the steering angle follows the
  command after the same transport delay at the servo rate; the pose follows the kinematic
  bicycle model about the rear axle, :math:`\dot x = v\cos\theta`,
  :math:`\dot y = v\sin\theta`, :math:`\dot\theta = v\tan\delta / L`, integrated exactly
  along circular arcs over 10 ms sub-steps.
- :class:`PybulletCar`: a rigid multibody (chassis, two steering knuckles, four wheels) in
  pybullet at 240 Hz: the knuckles are position-controlled to the Ackermann angles of the
  steering state, the rear wheels velocity-controlled (force-limited) to the speed of the same
  drive chain with the Ackermann differential; the pose is read back from the simulation.

How :class:`robots.DriveParams` map onto the car (``get_drive_params`` /
``set_drive_params``, so :class:`randomizers.DynamicsRandomizer` applies): ``delay_s`` delays
both speed and steering commands; ``speed_lim_v_mps``, ``accel_lim_v_mps2``, the wheel loop,
friction and ``added_mass_kg`` shape the speed; ``speed_lim_w_radps`` caps the yaw rate
:math:`v\tan\delta/L` (a speed-dependent steering limit). The yaw-axis dynamics fields
(``accel_lim_w_radps2``, ``coulomb_w_nm``, ``viscous_w_nms_per_rad``,
``added_yaw_inertia_kgm2``) have no effect: the yaw rate is set by the steering geometry.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

from robots.params import BaseGeometry, DriveParams
from robots.reduced import ReducedDrive
from sim2real.envs._robot import arc_step
from sim2real.errors import Sim2RealValueError

__all__ = ["CAR", "DEFAULT_CAR_PARAMS", "CarGeometry", "CarModel", "PybulletCar", "ReducedCar"]


@dataclass(frozen=True, kw_only=True)
class CarGeometry:
    """Dimensions and actuator limits of the car (SI units in the names)."""

    chassis_length_m: float = 0.26
    chassis_width_m: float = 0.18
    chassis_height_m: float = 0.05
    wheel_radius_m: float = 0.05
    wheel_width_m: float = 0.03
    wheelbase_m: float = 0.18
    track_m: float = 0.22
    mass_kg: float = 1.0
    max_steer_rad: float = math.radians(30.0)
    steer_rate_radps: float = 3.0

    @property
    def footprint_length_m(self) -> float:
        """Length of the collision rectangle (the chassis), m."""
        return max(self.chassis_length_m, self.wheelbase_m + 2.0 * self.wheel_radius_m)

    @property
    def footprint_width_m(self) -> float:
        """Width of the collision rectangle (track plus a wheel width), m."""
        return max(self.chassis_width_m, self.track_m + self.wheel_width_m)

    def base_geometry(self) -> BaseGeometry:
        """The drive model's view of the car (rear axle as the drive axle)."""
        inertia = self.mass_kg * (self.chassis_length_m**2 + self.chassis_width_m**2) / 12.0
        return BaseGeometry(
            mass_kg=self.mass_kg,
            yaw_inertia_kgm2=inertia,
            wheel_radius_m=self.wheel_radius_m,
            wheel_separation_m=self.track_m,
        )


#: The car of Trararak et al.
CAR = CarGeometry()

#: Default drive chain of the car: 50 ms dead time, speed clamp 1.2 m/s, 1 m/s^2 rate limit,
#: a stiff wheel loop (time constant ~25 ms) and no yaw-rate cap.
DEFAULT_CAR_PARAMS = DriveParams(
    delay_s=0.05,
    speed_lim_v_mps=1.2,
    accel_lim_v_mps2=1.0,
    motor_gain_nms_per_rad=0.05,
    wheel_torque_max_nm=0.5,
    coulomb_v_fwd_n=0.05,
    coulomb_v_bwd_n=0.05,
    viscous_v_ns_per_m=0.1,
)

_SUBSTEP_S = 0.01
_KNUCKLES = (0, 2)  # pybullet joint indices of the car multibody (left, right)
_FRONT_WHEELS = (1, 3)
_REAR_WHEELS = (4, 5)


class CarModel(Protocol):
    """What the car env needs from a back-end."""

    @property
    def pose(self) -> tuple[float, float, float]:
        """Chassis centre (x [m], y [m], yaw [rad])."""
        ...

    @property
    def speed_mps(self) -> float:
        """Forward speed, m/s."""
        ...

    @property
    def steer_rad(self) -> float:
        """Steering angle of the virtual centre wheel, rad (positive = left)."""
        ...

    def reset(self, x: float, y: float, yaw: float, speed_mps: float) -> None:
        """Place the car, rolling at ``speed_mps`` straight ahead."""

    def step(self, cmd_v: float, cmd_steer: float, duration_s: float) -> None:
        """Hold the command (speed m/s, steering rad) for ``duration_s``."""

    def get_drive_params(self) -> DriveParams:
        """The drive parameters in use."""
        ...

    def set_drive_params(self, params: DriveParams) -> None:
        """Replace the drive parameters."""


class _Steering:
    """Steering servo: the command acts after the transport delay, at a limited rate."""

    def __init__(self, geometry: CarGeometry) -> None:
        self.geometry = geometry
        self.reset()

    def reset(self) -> None:
        self.angle_rad = 0.0
        self.time_s = 0.0
        self._history: list[tuple[float, float]] = [(-math.inf, 0.0)]

    def command(self, angle_rad: float) -> None:
        lim = self.geometry.max_steer_rad
        self._history.append((self.time_s, min(max(angle_rad, -lim), lim)))

    def advance(self, h: float, delay_s: float) -> float:
        """Move the angle over ``h`` s; returns the angle at the end."""
        self.time_s += h
        t_eff = self.time_s - delay_s
        target = self._history[0][1]
        keep = 0
        for k, (t, a) in enumerate(self._history):
            if t <= t_eff + 1e-12:
                target, keep = a, k
        del self._history[:keep]  # older commands can no longer act
        step = self.geometry.steer_rate_radps * h
        self.angle_rad += min(max(target - self.angle_rad, -step), step)
        return self.angle_rad


def _check_params(params: DriveParams) -> DriveParams:
    if not isinstance(params, DriveParams):
        raise Sim2RealValueError(
            f"set_drive_params needs a robots.DriveParams, got {type(params).__name__}"
        )
    return params


class ReducedCar:
    """Drive chain (numba) for the speed, delayed rate-limited steering, kinematic bicycle."""

    def __init__(self, geometry: CarGeometry = CAR, params: DriveParams = DEFAULT_CAR_PARAMS):
        self.geometry = geometry
        self._drive = ReducedDrive(_check_params(params), geometry.base_geometry())
        self._steer = _Steering(geometry)
        self._rear = (0.0, 0.0, 0.0)

    @property
    def pose(self) -> tuple[float, float, float]:
        x, y, yaw = self._rear
        half = 0.5 * self.geometry.wheelbase_m
        return x + half * math.cos(yaw), y + half * math.sin(yaw), yaw

    @property
    def speed_mps(self) -> float:
        return self._drive.velocity[0]

    @property
    def steer_rad(self) -> float:
        return self._steer.angle_rad

    def reset(self, x: float, y: float, yaw: float, speed_mps: float) -> None:
        half = 0.5 * self.geometry.wheelbase_m
        self._rear = (x - half * math.cos(yaw), y - half * math.sin(yaw), yaw)
        self._drive.reset(float(speed_mps), 0.0)
        self._steer.reset()

    def step(self, cmd_v: float, cmd_steer: float, duration_s: float) -> None:
        self._steer.command(cmd_steer)
        n = max(1, math.ceil(duration_s / _SUBSTEP_S - 1e-9))
        h = duration_s / n
        x, y, yaw = self._rear
        params = self._drive.params
        length = self.geometry.wheelbase_m
        for _ in range(n):
            v0 = self._drive.velocity[0]
            v1 = self._drive.step(cmd_v, 0.0, h)[0]
            v = 0.5 * (v0 + v1)
            delta = self._steer.advance(h, params.delay_s)
            w = v * math.tan(delta) / length
            w_cap = params.speed_lim_w_radps
            w = min(max(w, -w_cap), w_cap)
            x, y, yaw = arc_step(x, y, yaw, v, w, h)
        self._rear = (x, y, yaw)

    def get_drive_params(self) -> DriveParams:
        return self._drive.params

    def set_drive_params(self, params: DriveParams) -> None:
        self._drive.params = _check_params(params)


class PybulletCar:
    """The car as a pybullet multibody (chassis, steering knuckles, four wheels) at 240 Hz.

    Parameters
    ----------
    client : int
        pybullet client (the env's DIRECT client, with a ground).
    geometry : CarGeometry
        Dimensions.
    params : DriveParams
        Drive chain of the speed (see the module docstring).
    """

    _PHYSICS_HZ = 240.0

    def __init__(
        self,
        client: int,
        geometry: CarGeometry = CAR,
        params: DriveParams = DEFAULT_CAR_PARAMS,
    ) -> None:
        import pybullet as p

        self.p, self.client, self.geometry = p, client, geometry
        self._chain = ReducedDrive(_check_params(params), geometry.base_geometry())
        self._steer = _Steering(geometry)
        self.body_id = -1

    # ------------------------------------------------------------------ building
    def _shapes(self) -> tuple[int, int, int, int, int]:
        """pybullet shapes of the chassis (collision, visual), a wheel (collision, visual) and
        a steering knuckle (collision)."""
        p, c, g = self.p, self.client, self.geometry
        half = [0.5 * g.chassis_length_m, 0.5 * g.chassis_width_m, 0.5 * g.chassis_height_m]
        chassis_col = p.createCollisionShape(p.GEOM_BOX, halfExtents=half, physicsClientId=c)
        chassis_vis = p.createVisualShape(
            p.GEOM_BOX, halfExtents=half, rgbaColor=[0.1, 0.3, 0.8, 1.0], physicsClientId=c
        )
        # wheel cylinders lie along the local y axis
        wheel_orn = p.getQuaternionFromEuler([0.5 * math.pi, 0.0, 0.0])
        wheel_col = p.createCollisionShape(
            p.GEOM_CYLINDER,
            radius=g.wheel_radius_m,
            height=g.wheel_width_m,
            collisionFrameOrientation=wheel_orn,
            physicsClientId=c,
        )
        wheel_vis = p.createVisualShape(
            p.GEOM_CYLINDER,
            radius=g.wheel_radius_m,
            length=g.wheel_width_m,
            visualFrameOrientation=wheel_orn,
            rgbaColor=[0.1, 0.1, 0.1, 1.0],
            physicsClientId=c,
        )
        knuckle_col = p.createCollisionShape(p.GEOM_SPHERE, radius=0.005, physicsClientId=c)
        return chassis_col, chassis_vis, wheel_col, wheel_vis, knuckle_col

    def _build(self, x: float, y: float, yaw: float) -> None:
        p, c, g = self.p, self.client, self.geometry
        chassis_col, chassis_vis, wheel_col, wheel_vis, knuckle_col = self._shapes()
        hx, hy = 0.5 * g.wheelbase_m, 0.5 * g.track_m
        z_axle = g.wheel_radius_m
        # base frame at the chassis centre, at axle height
        # (mass, col, vis, parent (0 = base, k = k-th link), pos, joint type, axis), in the
        # depth-first order pybullet stores links in: joints 0/2 steer, 1/3 front, 4/5 rear
        links = [
            (0.01, knuckle_col, -1, 0, [hx, hy, 0.0], p.JOINT_REVOLUTE, [0, 0, 1]),
            (0.05, wheel_col, wheel_vis, 1, [0.0, 0.0, 0.0], p.JOINT_REVOLUTE, [0, 1, 0]),
            (0.01, knuckle_col, -1, 0, [hx, -hy, 0.0], p.JOINT_REVOLUTE, [0, 0, 1]),
            (0.05, wheel_col, wheel_vis, 3, [0.0, 0.0, 0.0], p.JOINT_REVOLUTE, [0, 1, 0]),
            (0.05, wheel_col, wheel_vis, 0, [-hx, hy, 0.0], p.JOINT_REVOLUTE, [0, 1, 0]),
            (0.05, wheel_col, wheel_vis, 0, [-hx, -hy, 0.0], p.JOINT_REVOLUTE, [0, 1, 0]),
        ]
        wheels_mass = sum(link[0] for link in links)
        ident = [0.0, 0.0, 0.0, 1.0]
        self.body_id = p.createMultiBody(
            baseMass=max(g.mass_kg - wheels_mass, 0.1),
            baseCollisionShapeIndex=chassis_col,
            baseVisualShapeIndex=chassis_vis,
            basePosition=[x, y, z_axle],
            baseOrientation=p.getQuaternionFromEuler([0.0, 0.0, yaw]),
            linkMasses=[link[0] for link in links],
            linkCollisionShapeIndices=[link[1] for link in links],
            linkVisualShapeIndices=[link[2] for link in links],
            linkPositions=[link[4] for link in links],
            linkOrientations=[ident] * len(links),
            linkInertialFramePositions=[[0.0, 0.0, 0.0]] * len(links),
            linkInertialFrameOrientations=[ident] * len(links),
            linkParentIndices=[link[3] for link in links],
            linkJointTypes=[link[5] for link in links],
            linkJointAxis=[link[6] for link in links],
            physicsClientId=c,
        )
        self._configure(len(links))

    def _configure(self, n_links: int) -> None:
        """Friction, no contacts inside the car, free-rolling front wheels."""
        p, c = self.p, self.client
        # the chassis floats between the wheels (ground clearance = wheel radius - half height)
        for j in range(n_links):
            p.changeDynamics(
                self.body_id, j, lateralFriction=1.0, rollingFriction=0.0, physicsClientId=c
            )
        p.changeDynamics(self.body_id, -1, lateralFriction=0.0, physicsClientId=c)
        for j in range(n_links):  # no contacts inside the car
            for k in range(-1, j):
                p.setCollisionFilterPair(self.body_id, self.body_id, k, j, 0, physicsClientId=c)
        for j in _FRONT_WHEELS:  # front wheels roll freely
            p.setJointMotorControl2(
                self.body_id,
                j,
                p.VELOCITY_CONTROL,
                targetVelocity=0.0,
                force=0.0,
                physicsClientId=c,
            )

    # ------------------------------------------------------------------ interface
    @property
    def pose(self) -> tuple[float, float, float]:
        pos, orn = self.p.getBasePositionAndOrientation(self.body_id, physicsClientId=self.client)
        yaw = self.p.getEulerFromQuaternion(orn)[2]
        return float(pos[0]), float(pos[1]), float(yaw)

    @property
    def speed_mps(self) -> float:
        lin, _ = self.p.getBaseVelocity(self.body_id, physicsClientId=self.client)
        yaw = self.pose[2]
        return float(lin[0] * math.cos(yaw) + lin[1] * math.sin(yaw))

    @property
    def steer_rad(self) -> float:
        return self._steer.angle_rad

    def reset(self, x: float, y: float, yaw: float, speed_mps: float) -> None:
        """Build a new body (the env resets the simulation first) rolling at ``speed_mps``."""
        self._build(x, y, yaw)
        p, c = self.p, self.client
        v = float(speed_mps)
        p.resetBaseVelocity(
            self.body_id,
            [v * math.cos(yaw), v * math.sin(yaw), 0.0],
            [0, 0, 0],
            physicsClientId=c,
        )
        for j in (*_FRONT_WHEELS, *_REAR_WHEELS):
            p.resetJointState(
                self.body_id, j, 0.0, v / self.geometry.wheel_radius_m, physicsClientId=c
            )
        self._chain.reset(v, 0.0)
        self._steer.reset()

    def step(self, cmd_v: float, cmd_steer: float, duration_s: float) -> None:
        p, c, g = self.p, self.client, self.geometry
        self._steer.command(cmd_steer)
        n = max(1, round(duration_s * self._PHYSICS_HZ))
        h = duration_s / n
        params = self._chain.params
        for _ in range(n):
            v_ref = self._chain.step(cmd_v, 0.0, h)[0]
            delta = self._steer.advance(h, params.delay_s)
            if math.isfinite(params.speed_lim_w_radps) and abs(v_ref) > 1e-6:
                cap = math.atan(params.speed_lim_w_radps * g.wheelbase_m / abs(v_ref))
                delta = min(max(delta, -cap), cap)
            t = math.tan(delta)
            # Ackermann: inner and outer wheels turn about the same point on the rear axle
            left = math.atan2(g.wheelbase_m * t, g.wheelbase_m - 0.5 * g.track_m * t)
            right = math.atan2(g.wheelbase_m * t, g.wheelbase_m + 0.5 * g.track_m * t)
            p.setJointMotorControlArray(
                self.body_id,
                list(_KNUCKLES),
                p.POSITION_CONTROL,
                targetPositions=[left, right],
                forces=[5.0, 5.0],
                physicsClientId=c,
            )
            k = 0.5 * g.track_m * t / g.wheelbase_m
            w_ref = v_ref / g.wheel_radius_m
            torque = params.wheel_torque_max_nm
            force = torque if math.isfinite(torque) else 10.0
            p.setJointMotorControlArray(
                self.body_id,
                list(_REAR_WHEELS),
                p.VELOCITY_CONTROL,
                targetVelocities=[w_ref * (1.0 - k), w_ref * (1.0 + k)],
                forces=[force, force],
                physicsClientId=c,
            )
            p.stepSimulation(physicsClientId=c)

    def get_drive_params(self) -> DriveParams:
        return self._chain.params

    def set_drive_params(self, params: DriveParams) -> None:
        self._chain.params = _check_params(params)
