"""The pybullet robot without the spec check (private; :mod:`robots.pybullet_robot` is public).

:class:`UncheckedPybulletRobot` is :class:`robots.pybullet_robot.PybulletRobot` less the
:func:`robots.check.ensure_spec_ok` gate, so that the check's own drive test can build one.
The model is described in :mod:`robots.pybullet_robot`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from types import TracebackType
from typing import TypeVar

import numpy as np
from numpy.typing import NDArray

from robots._kernel import pack_params, pybullet_substep
from robots._pybullet import pybullet as p
from robots._urdf import LEFT_WHEEL_JOINT, RIGHT_WHEEL_JOINT, urdf_path
from robots.arrays import FloatArray
from robots.errors import RobotsError, RobotsValueError
from robots.measurement import yaw_reading_factor
from robots.params import DriveParams
from robots.reduced import _check_inputs, _delayed_commands, delayed_step_average
from robots.spec import RobotSpec, load_spec, lumped_base_inertia, lumped_base_mass_kg
from robots.units import GRAVITY_MPS2 as _G
from robots.world import add_ground

_Robot = TypeVar("_Robot", bound="UncheckedPybulletRobot")

#: Least lateral friction coefficient of the wheel tyres (times the ground's 1.0); a drive that
#: asks more gets more (:func:`tyre_friction`).
WHEEL_FRICTION = 1.5
#: :func:`tyre_friction` divides by at least this share of a wheel's static load: below it the
#: base is about to tip onto a caster under the drive's peak forces, where pybullet parts from
#: the reduced model whatever the tyres (a wheel leaves the ground).
MIN_LOAD_FRACTION = 0.1
#: A load the drive puts on a caster at once (a torque step) peaks at twice its steady value on
#: the stiff, undamped contact (the dynamic load factor of a suddenly applied load).
LOAD_STEP_FACTOR = 2.0
#: Constraint-solver iterations per physics step (set on the client, with pyramid friction).
#: pybullet's default 50 leaves the wheel contacts unconverged (the yaw rate is off and ripples
#: at the wheel revolution rate); 150 converges at almost no cost (the solver stops early). Its
#: default cone friction lets a wheel slide for several physics steps when its torque jumps to
#: saturation (a reversal); pyramid friction (``enableConeFriction=0``) holds it, and is
#: faster.
SOLVER_ITERATIONS = 150

_WHEELS = [LEFT_WHEEL_JOINT, RIGHT_WHEEL_JOINT]
_WHEEL_TUPLE = (LEFT_WHEEL_JOINT, RIGHT_WHEEL_JOINT)
#: Target positions, velocities and gains of the wheels' ``setJointMotorControlArray`` calls:
#: ``TORQUE_CONTROL`` reads only the forces, but they come after these in pybullet's argument
#: list, and passing every argument by position (``physicsClientId`` last) halves the call's
#: cost (pybullet parses keyword arguments on every call).
_UNUSED = (0.0, 0.0)
#: :meth:`PybulletRobot.replay` reads the base pose at least every this many physics steps, so
#: its yaw unwraps (less than pi per 8 steps of 1/240 s below 94 rad/s).
_YAW_SAMPLE_STEPS = 8
_REL_TOL = 1e-6
#: Height a :meth:`PybulletRobot.reset` lifts the robot to before its collision-detection pass, m:
#: far beyond pybullet's 0.02 m contact breaking threshold and any obstacle (not below the
#: ground: the ground plane is a half space).
_LIFT_M = 1000.0


def tyre_friction(spec: RobotSpec, params: DriveParams) -> float:
    r"""Tyre friction coefficient with which the pybullet wheels carry every force ``params`` asks.

    The reduced model's wheels never slip; the pybullet robot carries the loops' torques and
    the axis friction through its tyres (:mod:`robots.pybullet_robot`, step 4), so a tyre
    grips while its force stays below :math:`\mu N`. Per wheel, the drive asks at most

    .. math:: F = \tau_{max}/r + (C_v + b_v v_{max})/2 + (C_w + b_w w_{max})/L

    (the torque cap, or twice the stall torque when the motors' torque-speed line binds: a
    reversal at speed; half the forward friction and the yaw friction as a force pair at the
    track :math:`L`), and the lateral force :math:`m a_{lat}/2`, :math:`a_{lat} = v w \le
    v_{max}^2/(2 \chi L)` (skid steer: effective track :math:`\chi L`). Its normal load is the
    static :math:`m g/2` less the load the base moves onto a caster at :math:`x_c` when it
    brakes at :math:`a = (2\tau_{max}/r + C_v + b_v v_{max})/m` (its centre of mass at the
    height :math:`h` of ``base_link``: :math:`m a h/(2 x_c)`) and onto the outer wheel in a
    turn (:math:`m a_{lat} h/L`), both times :data:`LOAD_STEP_FACTOR` (they come as steps),
    at least :data:`MIN_LOAD_FRACTION` of the static load.
    Here :math:`m` is the rigid mass with ``added_mass_kg``. Pybullet's pyramid friction
    bounds the two directions apart, so the larger of :math:`F/N` and :math:`m a_{lat}/(2N)`
    counts. A drive with no torque or speed bound (inf) keeps :data:`WHEEL_FRICTION`.

    Parameters
    ----------
    spec : RobotSpec
        The robot (wheels, casters, base_link height, rigid mass).
    params : DriveParams
        The drive parameters the robot runs.

    Returns
    -------
    float
        The tyres' lateral friction coefficient (times the ground's): the larger of
        :data:`WHEEL_FRICTION` and the one the drive needs.

    Examples
    --------
    >>> from robots import load_spec
    >>> spec = load_spec("turtlebot3_burger")
    >>> tyre_friction(spec, spec.drive)  # its drive needs mu 0.82 at most
    1.5
    """
    d = params
    r, sep = spec.wheels.radius_m, spec.wheels.separation_m
    line = math.isfinite(d.wheel_stall_torque_nm) and math.isfinite(d.wheel_no_load_speed_radps)
    tau = (
        min(d.wheel_torque_max_nm, 2.0 * d.wheel_stall_torque_nm) if line else d.wheel_torque_max_nm
    )
    v_wheels = d.wheel_speed_max_radps * r
    v_max = min(d.speed_lim_v_mps, v_wheels)
    w_max = min(d.speed_lim_w_radps, 2.0 * v_wheels / (d.track_factor * sep))
    friction_v = max(d.coulomb_v_fwd_n, d.coulomb_v_bwd_n) + d.viscous_v_ns_per_m * v_max
    friction_w = d.coulomb_w_nm + d.viscous_w_nms_per_rad * w_max
    force = tau / r + 0.5 * friction_v + friction_w / sep
    if not math.isfinite(force):
        return WHEEL_FRICTION
    mass = spec.rigid_mass_kg + d.added_mass_kg
    a_brake = (2.0 * tau / r + friction_v) / mass
    a_lat = min(v_max * w_max, v_wheels**2 / (2.0 * d.track_factor * sep))
    h = spec.base_link_height_m
    reach = [abs(c.xyz_m[0]) for c in spec.casters if abs(c.xyz_m[0]) > 0.0]
    pitch = mass * a_brake * h / (2.0 * min(reach)) if reach else 0.0
    static = 0.5 * mass * _G
    moved = LOAD_STEP_FACTOR * (pitch + mass * a_lat * h / sep)
    load = max(static - moved, MIN_LOAD_FRACTION * static)
    return max(WHEEL_FRICTION, max(force, 0.5 * mass * a_lat) / load)


class DriveParamsNotAppliedError(RobotsError, RuntimeError):
    """pybullet did not take a parameter (read-back differs from what was set)."""


@dataclass(frozen=True, kw_only=True)
class PybulletResponse:
    """What :meth:`PybulletRobot.replay` returns, at the requested times.

    Attributes
    ----------
    t_s : ndarray
        Output times, s.
    v, w : ndarray
        True forward velocity (m/s) and yaw rate (rad/s) of the base.
    odom_v, odom_w : ndarray
        Odometry as the base reports it (:meth:`PybulletRobot.odometry`), m/s and rad/s.
    x_m, y_m, yaw_rad : ndarray
        Pose of base_link on the ground (yaw unwrapped), m and rad.
    """

    t_s: FloatArray
    v: FloatArray
    w: FloatArray
    odom_v: FloatArray
    odom_w: FloatArray
    x_m: FloatArray
    y_m: FloatArray
    yaw_rad: FloatArray


def _check_pose(x: float, y: float, yaw: float) -> None:
    for name, val in (("x", x), ("y", y), ("yaw", yaw)):
        if not math.isfinite(val):
            raise RobotsValueError(f"reset pose {name} must be finite, got {val!r}")


def _yaw_of(quat: Sequence[float]) -> float:
    x, y, z, w = quat
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


class UncheckedPybulletRobot:
    """:class:`robots.pybullet_robot.PybulletRobot` without the spec check (same parameters).

    :meth:`_admit` is where a subclass refuses a spec before the robot is built.
    """

    def __init__(
        self,
        spec: RobotSpec | str,
        *,
        client: int | None = None,
        params: DriveParams | None = None,
        physics_hz: float = 240.0,
        start_pose: tuple[float, float, float] = (0.0, 0.0, 0.0),
    ) -> None:
        self.spec = spec if isinstance(spec, RobotSpec) else load_spec(spec)
        self._admit(self.spec)
        if not (math.isfinite(physics_hz) and physics_hz > 0):
            raise RobotsValueError(f"physics_hz must be a finite number > 0, got {physics_hz!r}")
        self.physics_hz = float(physics_hz)
        self.dt_s = 1.0 / self.physics_hz
        self._own_client = client is None
        if client is None:
            client = int(p.connect(p.DIRECT))
            p.setGravity(0.0, 0.0, -_G, physicsClientId=client)
            add_ground(client)
        self.client = client
        gravity = p.getPhysicsEngineParameters(physicsClientId=client)["gravityAccelerationZ"]
        if not gravity < -1.0:
            raise RobotsValueError(
                f"pybullet client {client} has gravity z = {gravity} m/s^2; the wheels need "
                "weight to grip: call pybullet.setGravity(0, 0, -9.81) before adding the robot"
            )
        p.setPhysicsEngineParameter(
            fixedTimeStep=self.dt_s,
            numSolverIterations=SOLVER_ITERATIONS,
            enableConeFriction=0,
            physicsClientId=client,
        )
        self.body_id = int(
            p.loadURDF(
                str(urdf_path(self.spec)),
                flags=p.URDF_USE_INERTIA_FROM_FILE,
                physicsClientId=client,
            )
        )
        self._setup_contacts()
        # the velocity smoother's reference, the base yaw and the wheel-loop integrators
        # [ref_v, ref_w, yaw, ir, il], advanced in place by the kernel
        self._state = np.zeros(5)
        wheels = self.spec.wheels
        self._wheel_radius_m, self._wheel_separation_m = wheels.radius_m, wheels.separation_m
        self._spin_inertia = wheels.spin_inertia_kgm2
        self.set_drive_params(params or self.spec.drive)
        _check_pose(*start_pose)
        self._place(*start_pose)  # a new body has no contacts yet: nothing for reset to drop

    # ------------------------------------------------------------------ set-up

    def _admit(self, spec: RobotSpec) -> None:
        """Refuse a spec before anything is built (none here; :class:`PybulletRobot` checks it)."""

    def _setup_contacts(self) -> None:
        c, body = self.client, self.body_id
        p.setJointMotorControlArray(
            body, _WHEELS, p.VELOCITY_CONTROL, forces=[0.0, 0.0], physicsClientId=c
        )
        for j in [-1, *_WHEELS]:
            # only touching contacts act: stale manifold points of the rolling wheels would
            # otherwise keep pushing sideways for a few steps
            p.changeDynamics(body, j, contactProcessingThreshold=0.0, physicsClientId=c)
        p.changeDynamics(
            body,
            -1,
            lateralFriction=0.0,
            rollingFriction=0.0,
            spinningFriction=0.0,
            linearDamping=0.0,
            angularDamping=0.0,
            restitution=0.0,
            physicsClientId=c,
        )
        for j in range(p.getNumJoints(body, physicsClientId=c)):
            p.changeDynamics(
                body,
                j,
                linearDamping=0.0,
                angularDamping=0.0,
                jointDamping=0.0,
                physicsClientId=c,
            )
        for j in _WHEELS:
            p.changeDynamics(
                body,
                j,
                rollingFriction=0.0,
                spinningFriction=0.0,
                restitution=0.0,
                physicsClientId=c,
            )

    def close(self) -> None:
        """Disconnect the pybullet client if this robot created it."""
        if self._own_client and p.isConnected(self.client):
            p.disconnect(self.client)

    def __enter__(self: _Robot) -> _Robot:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    # ------------------------------------------------------------------ drive parameters

    def get_drive_params(self) -> DriveParams:
        """The drive parameters in use."""
        return self._params

    def set_drive_params(self, params: DriveParams) -> None:
        """Apply ``params``: added mass/inertia via ``changeDynamics``, then read them back.

        Raises
        ------
        RobotsValueError
            The added mass or inertia would make the base link's mass or yaw inertia <= 0.
        DriveParamsNotAppliedError
            pybullet reports other values than those set.
        """
        if not isinstance(params, DriveParams):
            raise RobotsValueError(
                f"params must be a robots.DriveParams, got {type(params).__name__}"
            )
        geo = self.spec.geometry
        mass = lumped_base_mass_kg(self.spec) + params.added_mass_kg
        ixx, iyy, izz = lumped_base_inertia(self.spec)
        izz += params.added_yaw_inertia_kgm2
        if mass <= 0 or izz <= 0:
            raise RobotsValueError(
                f"added_mass_kg={params.added_mass_kg} / added_yaw_inertia_kgm2="
                f"{params.added_yaw_inertia_kgm2} leave the base link of '{self.spec.name}' with "
                f"mass {mass:.4g} kg and yaw inertia {izz:.4g} kg m^2; both must stay > 0"
            )
        p.changeDynamics(
            self.body_id,
            -1,
            mass=mass,
            localInertiaDiagonal=[ixx, iyy, izz],
            physicsClientId=self.client,
        )
        grip = tyre_friction(self.spec, params)
        for j in _WHEELS:
            p.changeDynamics(self.body_id, j, lateralFriction=grip, physicsClientId=self.client)
        self._check_applied(mass, (ixx, iyy, izz), grip)
        self._params = params
        self._packed = pack_params(params, geo)

    def _check_applied(self, mass: float, inertia: tuple[float, float, float], grip: float) -> None:
        c, body = self.client, self.body_id
        info = p.getDynamicsInfo(body, -1, physicsClientId=c)
        checks: list[tuple[str, float, float]] = [
            ("base mass [kg]", float(info[0]), mass),
            ("base lateral friction", float(info[1]), 0.0),
        ]
        checks += [(f"base inertia[{i}] [kg m^2]", float(info[2][i]), inertia[i]) for i in range(3)]
        for j in _WHEELS:
            winfo = p.getDynamicsInfo(body, j, physicsClientId=c)
            checks.append((f"wheel {j} lateral friction", float(winfo[1]), grip))
            checks.append((f"wheel {j} mass [kg]", float(winfo[0]), self.spec.wheels.mass_kg))
            w = self.spec.wheels
            wheel_inertia = (w.cross_inertia_kgm2, w.cross_inertia_kgm2, w.spin_inertia_kgm2)
            checks += [
                (f"wheel {j} inertia[{i}] [kg m^2]", float(winfo[2][i]), wheel_inertia[i])
                for i in range(3)
            ]
            jinfo = p.getJointInfo(body, j, physicsClientId=c)
            checks.append(
                (f"joint {j} type (0 = revolute)", float(jinfo[2]), float(p.JOINT_REVOLUTE))
            )
            checks.append((f"joint {j} damping", float(jinfo[6]), 0.0))
            checks.append((f"joint {j} friction", float(jinfo[7]), 0.0))
        for what, got, want in checks:
            if abs(got - want) > _REL_TOL * max(1.0, abs(want)):
                raise DriveParamsNotAppliedError(
                    f"pybullet did not take {what} of robot '{self.spec.name}': set {want!r}, "
                    f"read back {got!r}; check the pybullet version and the generated URDF"
                )

    # ------------------------------------------------------------------ state

    def reset(self, x: float = 0.0, y: float = 0.0, yaw: float = 0.0) -> None:
        """Put the robot at rest at (x, y, yaw) on the ground, as a fresh robot; clear the history.

        The run that follows gives the numbers of a robot just built at that pose, bit for bit
        (tests/robots/test_robots_pybullet_reset.py), also in a client shared with other bodies.

        Parameters
        ----------
        x, y : float
            Position of base_link on the ground, m.
        yaw : float
            Heading, rad.

        Notes
        -----
        pybullet keeps a contact point, and the impulse it carried in the last physics step
        (the solver's warm start), while the two bodies stay within the contact breaking
        threshold, whatever ``resetBasePositionAndOrientation`` does: put back where it stood,
        a robot would start from its last wheel impulses. So the robot is first lifted
        :data:`_LIFT_M` above the ground and one collision-detection pass
        (``performCollisionDetection``) drops its contact points and its pairs with obstacles;
        the other bodies of a shared client keep theirs.
        """
        _check_pose(x, y, yaw)
        c = self.client
        p.resetBasePositionAndOrientation(
            self.body_id, [x, y, _LIFT_M], [0.0, 0.0, 0.0, 1.0], physicsClientId=c
        )
        p.performCollisionDetection(physicsClientId=c)
        self._place(x, y, yaw)

    def _place(self, x: float, y: float, yaw: float) -> None:
        """Put the body at rest at (x, y, yaw) and clear the drive state (not pybullet's)."""
        c, body = self.client, self.body_id
        z = self.spec.base_link_height_m
        quat = [0.0, 0.0, math.sin(0.5 * yaw), math.cos(0.5 * yaw)]
        p.resetBasePositionAndOrientation(body, [x, y, z], quat, physicsClientId=c)
        p.resetBaseVelocity(body, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], physicsClientId=c)
        for j in _WHEELS:
            p.resetJointState(body, j, 0.0, 0.0, physicsClientId=c)
        self._state[:] = 0.0
        self.time_s = 0.0
        self._cmd_t: list[float] = []
        self._cmd_v: list[float] = []
        self._cmd_w: list[float] = []
        self._last_torques = (0.0, 0.0)

    def set_velocity(self, v: float, w: float) -> None:
        """Give the base forward speed ``v`` (m/s) and yaw rate ``w`` (rad/s) now.

        The wheels get the matching rolling speeds and the velocity smoother's reference is set
        to (v, w), as the reduced model's ``v0``/``w0`` do; the command history is kept.
        """
        if not (math.isfinite(v) and math.isfinite(w)):
            raise RobotsValueError(f"velocity must be finite, got ({v!r}, {w!r})")
        c, body = self.client, self.body_id
        _, orn = p.getBasePositionAndOrientation(body, physicsClientId=c)
        yaw = _yaw_of(orn)
        p.resetBaseVelocity(
            body, [v * math.cos(yaw), v * math.sin(yaw), 0.0], [0.0, 0.0, w], physicsClientId=c
        )
        r, half = self.spec.wheels.radius_m, 0.5 * self.spec.wheels.separation_m
        for j, side in ((LEFT_WHEEL_JOINT, -1.0), (RIGHT_WHEEL_JOINT, 1.0)):
            angle = p.getJointState(body, j, physicsClientId=c)[0]
            p.resetJointState(body, j, angle, (v + side * w * half) / r, physicsClientId=c)
        self._state[0], self._state[1] = v, w
        self._state[3], self._state[4] = 0.0, 0.0

    @property
    def pose(self) -> tuple[float, float, float]:
        """(x [m], y [m], yaw [rad]) of base_link projected on the ground."""
        pos, orn = p.getBasePositionAndOrientation(self.body_id, physicsClientId=self.client)
        return float(pos[0]), float(pos[1]), _yaw_of(orn)

    @property
    def velocity(self) -> tuple[float, float]:
        """True (v [m/s] along the heading, w [rad/s] about the vertical) of the base."""
        lin, ang = p.getBaseVelocity(self.body_id, physicsClientId=self.client)
        _, orn = p.getBasePositionAndOrientation(self.body_id, physicsClientId=self.client)
        yaw = _yaw_of(orn)
        return lin[0] * math.cos(yaw) + lin[1] * math.sin(yaw), float(ang[2])

    def wheel_contacts(self) -> tuple[bool, bool]:
        """Whether the (left, right) wheel links have contact points (the ground, an obstacle)."""
        c, body = self.client, self.body_id
        left, right = (
            p.getContactPoints(bodyA=body, linkIndexA=j, physicsClientId=c) for j in (0, 1)
        )
        return bool(left), bool(right)

    def wheel_speeds(self) -> tuple[float, float]:
        """(left, right) wheel joint speeds, rad/s (positive drives forward)."""
        states = p.getJointStates(self.body_id, _WHEELS, physicsClientId=self.client)
        return float(states[0][1]), float(states[1][1])

    @property
    def wheel_torques(self) -> tuple[float, float]:
        """(left, right) wheel torques applied in the last physics step, N m.

        The loops' torques plus the axis friction the wheels carry (see the module notes).
        """
        return self._last_torques

    def odometry(self) -> tuple[float, float]:
        """(v, w) as the base reports it: v from the wheel encoders, w per ``spec.odometry``.

        ``w_source == "imu"`` (TurtleBot 2 and 3) gives the gyro's yaw rate, i.e. the true body
        rate; ``"wheels"`` gives the encoders' reading, :math:`r(\\omega_r - \\omega_l)/L`
        times the effective over the driver's track (the tyres grip on the geometric track and
        the treads' slip is in the wheel loops: :func:`robots.measurement.yaw_reading_factor`).
        """
        wl, wr = self.wheel_speeds()
        r, sep = self.spec.wheels.radius_m, self.spec.wheels.separation_m
        v = 0.5 * r * (wr + wl)
        if self.spec.odometry.w_source == "imu":
            return v, self.velocity[1]
        return v, yaw_reading_factor("wheels", self._params) * r * (wr - wl) / sep

    # ------------------------------------------------------------------ stepping

    def step(self, cmd_v: float, cmd_w: float, duration_s: float) -> tuple[float, float]:
        """Issue command (cmd_v, cmd_w) now, run physics for ``duration_s``; return true (v, w).

        ``duration_s`` is rounded to a whole number (>= 1) of physics steps.
        """
        if not (math.isfinite(cmd_v) and math.isfinite(cmd_w)):
            raise RobotsValueError(f"command must be finite, got ({cmd_v!r}, {cmd_w!r})")
        self._check_duration(duration_s)
        self._cmd_t.append(self.time_s)
        self._cmd_v.append(float(cmd_v))
        self._cmd_w.append(float(cmd_w))
        return self.advance(duration_s)

    def advance(self, duration_s: float) -> tuple[float, float]:
        """Run physics for ``duration_s`` without a new command; return true (v, w).

        The last command holds until ``cmd_timeout_s`` after it was issued, then the base stops.
        """
        self._check_duration(duration_s)
        # forget commands that can no longer take effect (1 s of margin, as ReducedDrive keeps,
        # so raising the delay by up to 1 s later still finds the commands it needs)
        horizon = self.time_s - self._params.delay_s - 1.0
        while len(self._cmd_t) > 2 and self._cmd_t[1] < horizon:
            del self._cmd_t[0], self._cmd_v[0], self._cmd_w[0]
        n = max(1, round(duration_s * self.physics_hz))
        if self._cmd_t:
            u_v, u_w = _delayed_commands(
                np.array(self._cmd_t),
                np.array(self._cmd_v),
                np.array(self._cmd_w),
                self.time_s,
                self.dt_s,
                n,
                self._params.delay_s,
                self._params.cmd_timeout_s,
            )
            self._run(u_v.tolist(), u_w.tolist())
        else:
            self._run([0.0] * n, [0.0] * n)
        self.time_s += n * self.dt_s
        return self.velocity

    def _check_duration(self, duration_s: float) -> None:
        if not (math.isfinite(duration_s) and duration_s > 0):
            raise RobotsValueError(f"duration_s must be a finite number > 0, got {duration_s!r}")

    def _delayed(
        self, t: FloatArray, v: FloatArray, w: FloatArray, grid: FloatArray
    ) -> tuple[FloatArray, FloatArray]:
        kw = {"delay_s": self._params.delay_s, "timeout_s": self._params.cmd_timeout_s}
        return (
            delayed_step_average(t, v, grid, self.dt_s, **kw),
            delayed_step_average(t, w, grid, self.dt_s, **kw),
        )

    def replay(
        self,
        *,
        cmd_t_s: FloatArray,
        cmd_v: FloatArray,
        cmd_w: FloatArray,
        t_out_s: FloatArray,
        v0: float = 0.0,
        w0: float = 0.0,
    ) -> PybulletResponse:
        """Drive a logged command sequence, like :func:`robots.reduced.simulate` does.

        The robot is first reset at its current pose (:meth:`reset`) and given the velocity
        (``v0``, ``w0``) (:meth:`set_velocity`); the run starts at ``t_out_s[0]`` (same clock as
        ``cmd_t_s``; commands sent before it act through the delay as in ``simulate``) and the
        outputs are linearly interpolated from the physics steps at ``t_out_s``.

        Examples
        --------
        >>> import numpy as np
        >>> from robots import PybulletRobot
        >>> robot = PybulletRobot("turtlebot3_burger")
        >>> t = np.arange(0.0, 1.0, 0.1)
        >>> out = robot.replay(cmd_t_s=np.array([0.0]), cmd_v=np.array([0.2]),
        ...                    cmd_w=np.array([0.0]), t_out_s=t)
        >>> out.v.shape
        (10,)
        >>> robot.close()
        """
        cmd_t_s, cmd_v, cmd_w, t_out_s = (
            np.asarray(a, dtype=np.float64) for a in (cmd_t_s, cmd_v, cmd_w, t_out_s)
        )
        _check_inputs(cmd_t_s, cmd_v, cmd_w, t_out_s, self.dt_s)
        self.reset(*self.pose)
        self.set_velocity(float(v0), float(w0))
        t0 = float(t_out_s[0])
        n = max(1, math.ceil((float(t_out_s[-1]) - t0) / self.dt_s))
        grid = t0 + self.dt_s * np.arange(n + 1, dtype=np.float64)
        u_v, u_w = self._delayed(cmd_t_s, cmd_v, cmd_w, grid[:-1])
        u_v_list, u_w_list = u_v.tolist(), u_w.tolist()
        sampled = _sampled_steps(grid, t_out_s)
        self._sync_yaw()  # once: the kernel's yaw then advances over the whole run
        if 4 * sampled.size > grid.size:  # dense outputs (e.g. an odometry window): every step
            rows = self._run_recording(u_v_list, u_w_list)
            rows.append(self._sample())
            sampled = np.arange(grid.size)
        else:
            rows, start = [], 0
            for k in sampled.tolist():
                self._run(u_v_list[start:k], u_w_list[start:k], sync_yaw=False)
                rows.append(self._sample())
                start = k
        rec = np.array(rows, dtype=np.float64)
        self.time_s = n * self.dt_s
        rec[:, 6] = np.unwrap(rec[:, 6])
        col = [np.interp(t_out_s, grid[sampled], rec[:, j]) for j in range(7)]
        imu = self.spec.odometry.w_source == "imu"
        encoders = yaw_reading_factor("wheels", self._params) * col[3]
        return PybulletResponse(
            t_s=t_out_s,
            v=col[0],
            w=col[1],
            odom_v=col[2],
            odom_w=col[1] if imu else encoders,
            x_m=col[4],
            y_m=col[5],
            yaw_rad=col[6],
        )

    def _sample(self) -> tuple[float, ...]:
        """(v, w, odometry v, wheel-odometry w, x, y, yaw) now."""
        states = p.getJointStates(self.body_id, _WHEELS, physicsClientId=self.client)
        lin, ang = p.getBaseVelocity(self.body_id, physicsClientId=self.client)
        pos, orn = p.getBasePositionAndOrientation(self.body_id, physicsClientId=self.client)
        return self._record(states, lin, ang, pos, _yaw_of(orn))

    def _record(
        self,
        states: Sequence[Sequence[float]],
        lin: Sequence[float],
        ang: Sequence[float],
        pos: Sequence[float],
        yaw: float,
    ) -> tuple[float, ...]:
        r, sep = self.spec.wheels.radius_m, self.spec.wheels.separation_m
        wl, wr = states[0][1], states[1][1]
        v = lin[0] * math.cos(yaw) + lin[1] * math.sin(yaw)
        return (v, ang[2], 0.5 * r * (wr + wl), r * (wr - wl) / sep, pos[0], pos[1], yaw)

    def _sync_yaw(self) -> None:
        """Read the base's yaw into the kernel state (which then advances it by dt * w_z)."""
        c, body = self.client, self.body_id
        _, orn = p.getBasePositionAndOrientation(body, physicsClientId=c)
        _, ang = p.getBaseVelocity(body, physicsClientId=c)
        self._state[2] = _yaw_of(orn) - self.dt_s * ang[2]  # the kernel adds dt * w_z first

    def _run(self, u_v: list[float], u_w: list[float], *, sync_yaw: bool = True) -> None:
        """One physics step per delayed command (u_v[i], u_w[i]).

        Per step: two state reads (``getJointStates`` of both wheels, ``getBaseVelocity``), the
        drive arithmetic in one call of the shared kernel
        (:func:`robots._kernel.pybullet_substep`), both wheel torques in one
        ``setJointMotorControlArray``, ``stepSimulation``. The yaw is read once first
        (``sync_yaw``) and advanced by the kernel.
        """
        if not u_v:
            return
        if sync_yaw:
            self._sync_yaw()
        c, body, state, packed = self.client, self.body_id, self._state, self._packed
        dt, spin, joints, unused = self.dt_s, self._spin_inertia, _WHEEL_TUPLE, _UNUSED
        wheels, base = p.getJointStates, p.getBaseVelocity
        drive, simulate = p.setJointMotorControlArray, p.stepSimulation
        kernel, mode = pybullet_substep, p.TORQUE_CONTROL
        tl, tr = self._last_torques
        # positional arguments throughout (see _UNUSED): pybullet parses keywords per call
        for a, b in zip(u_v, u_w, strict=True):
            (_, wl, _, _), (_, wr, _, _) = wheels(body, joints, c)
            (vx, vy, _), (_, _, wz) = base(body, c)
            tl, tr = kernel(state, a, b, wl, wr, vx, vy, wz, dt, packed, spin)
            drive(body, joints, mode, unused, unused, (tl, tr), unused, unused, c)
            simulate(c)
        self._last_torques = (tl, tr)

    def _run_recording(self, u_v: list[float], u_w: list[float]) -> list[tuple[float, ...]]:
        """:meth:`_run` that also returns the state before each step (as :meth:`_sample`).

        Three state reads per step (the pose too); the kernel keeps advancing its own yaw, so
        the numbers equal :meth:`_run`'s whatever is recorded.
        """
        c, body, state, packed = self.client, self.body_id, self._state, self._packed
        dt, spin, joints, unused = self.dt_s, self._spin_inertia, _WHEEL_TUPLE, _UNUSED
        r, sep = self._wheel_radius_m, self._wheel_separation_m
        wheels, base, pose = p.getJointStates, p.getBaseVelocity, p.getBasePositionAndOrientation
        drive, simulate = p.setJointMotorControlArray, p.stepSimulation
        kernel, mode = pybullet_substep, p.TORQUE_CONTROL
        rows: list[tuple[float, ...]] = []
        tl, tr = self._last_torques
        for a, b in zip(u_v, u_w, strict=True):
            (_, wl, _, _), (_, wr, _, _) = wheels(body, joints, c)
            (vx, vy, _), (_, _, wz) = base(body, c)
            (x, y, _), orn = pose(body, c)
            yaw = _yaw_of(orn)
            tl, tr = kernel(state, a, b, wl, wr, vx, vy, wz, dt, packed, spin)
            v = vx * math.cos(yaw) + vy * math.sin(yaw)
            rows.append((v, wz, 0.5 * r * (wr + wl), r * (wr - wl) / sep, x, y, yaw))
            drive(body, joints, mode, unused, unused, (tl, tr), unused, unused, c)
            simulate(c)
        self._last_torques = (tl, tr)
        return rows


def _sampled_steps(grid: FloatArray, t_out_s: FloatArray) -> NDArray[np.intp]:
    """Indices of the physics-grid times :meth:`PybulletRobot.replay` records.

    The two grid times around each output time (so interpolating over the recorded ones gives
    what interpolating over every step would) and every :data:`_YAW_SAMPLE_STEPS`-th step (so
    the yaw unwraps), first and last included.
    """
    last = grid.size - 1
    below = np.clip(np.searchsorted(grid, t_out_s, side="right") - 1, 0, max(last - 1, 0))
    every = np.arange(0, last + 1, _YAW_SAMPLE_STEPS)
    steps: NDArray[np.intp] = np.unique(np.concatenate((below, below + 1, every, [last])))
    return steps[steps <= last]
