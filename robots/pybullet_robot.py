r"""A differential-drive robot in pybullet that runs the drive chain of :mod:`robots.params`.

The robot is a real rigid multibody (generated from its spec by :mod:`robots._urdf`) rolling on
the ground through wheel contacts. Each physics step applies the same chain as the reduced
model (:mod:`robots.reduced`):

1. transport delay: commands are kept in a history and the delayed, zero-order-hold command is
   averaged over each physics step (:func:`robots.reduced.delayed_step_average`; :meth:`step`
   takes the same numbers from the short recent history in one compiled call), with the
   command timeout;
2. firmware speed clamp, velocity-smoother rate limits, per-wheel speed cap (both wheels
   scaled together) -> wheel speed targets;
3. per-wheel PI speed loops :math:`\tau = \mathrm{clip}(K(e + k_i\int e\,dt), \pm\tau_{max})`,
   :math:`e = \omega_{ref}-\omega`, discretised exactly as the reduced model does (the shared kernel
   :func:`robots._kernel.pybullet_substep`: backward Euler while unsaturated, torques of the
   current wheel speeds when saturated), applied with ``TORQUE_CONTROL`` (the default velocity
   motors are disabled).
   The loops see the measured wheel speeds: while the tyres grip these equal the speeds implied
   by the base motion; a slipping wheel adds :math:`-K' s` for its slip :math:`s` (rad/s), with
   :math:`K' = K/(1 + dt\,K/J_w)` the gain of a free wheel of spin inertia :math:`J_w`;
4. Coulomb and viscous friction of the forward and yaw axes (:func:`robots._kernel.
   axis_friction`): :math:`-b v - c\,\mathrm{sgn}(v)` while moving, and while stuck just what
   holds the base (at most the Coulomb level), so it stops the base without reversing it and a
   drive below breakaway does not move it. It is carried by the wheels, as a drivetrain's and
   the tyres' rolling friction are: force :math:`f` and yaw torque :math:`\tau` become wheel
   torques :math:`r f/2 \pm r\tau/L` added to the loops' torques (computed from the forward
   and yaw axes, so the two Coulomb terms stay independent). While the tyres grip, the wheel
   torques are then exactly the generalised forces that take the rolling base to the reduced
   model's end-of-step velocity;
5. added mass and yaw inertia by ``changeDynamics`` on the base link (mass and
   ``localInertiaDiagonal``), read back with ``getDynamicsInfo``;
6. skid steer (``track_factor`` > 1): the two tyres grip and roll on the geometric track; the
   treads' slip is in the kernel's wheel loops (wheel speeds through the effective track) and
   its torques and axis friction take the base where the reduced model goes. The wheel
   odometry reads what the real encoders would: the joints' yaw rate times the effective
   over the driver's track (:func:`robots.measurement.yaw_reading_factor`), the wheels'
   speeds whatever the slip.

Contacts: tyre friction at least 1.5 x ground 1.0, and as much as the drive can ask
(:func:`tyre_friction`: a hard reversal brakes the base and moves weight onto a caster, which
a fixed 1.5 can leave short of grip), casters frictionless (the base link has zero
friction), link damping zero (pybullet's default 0.04 would add unmodelled drag), pyramid
friction and 150 solver iterations (:data:`SOLVER_ITERATIONS`), and only touching contact
points act.

Every physics step thus applies the reduced model's forces to a rigid multibody with real
contacts; on flat ground the two agree within the tolerances of
``tests/robots/test_robots_pybullet.py``, and they part where the reduced model has no say:
collisions, slopes, wheels leaving the ground.

Cost: besides ``stepSimulation``, a physics step makes two state reads (both wheels' speeds in
one ``getJointStates``, the base velocity), one compiled kernel call and one
``setJointMotorControlArray``, all with positional arguments; the yaw is read once per control
step and advanced in the kernel (``benchmarks/bench_perf.py`` splits the cost of a step). The
wheel loops stay out of pybullet's ``PD_CONTROL`` plugin: it reads each joint's state through
the client API on every tick, and its explicit P loop, with per-wheel friction standing in for
the axis friction, parts from the reduced model.

Synthetic ground truth for sysid: the default ``physics_hz=240`` equals
``1 / robots.reduced.DEFAULT_DT_S``, so both models step on the same grid and a least-squares
fit of the reduced model recovers the parameters of a pybullet run (tests). With another
physics rate, fit with ``simulate(..., dt_s=1 / physics_hz)``: a yaw loop's time constant is a
few physics steps (~20 ms on a TurtleBot3), so a mismatched step biases a fitted yaw inertia.

Examples
--------
>>> from robots import PybulletRobot, load_spec
>>> robot = PybulletRobot(load_spec("turtlebot3_burger"))
>>> for _ in range(20):
...     v, w = robot.step(0.2, 0.0, 0.1)
>>> round(v, 3)  # 0.2 m/s less the Coulomb and viscous droop of the P loops
0.194
>>> robot.close()
"""

from __future__ import annotations

from robots._pybullet_robot import (
    LOAD_STEP_FACTOR,
    MIN_LOAD_FRACTION,
    SOLVER_ITERATIONS,
    WHEEL_FRICTION,
    DriveParamsNotAppliedError,
    PybulletResponse,
    UncheckedPybulletRobot,
    tyre_friction,
)
from robots.check import ensure_spec_ok
from robots.spec import RobotSpec

__all__ = [
    "LOAD_STEP_FACTOR",
    "MIN_LOAD_FRACTION",
    "SOLVER_ITERATIONS",
    "WHEEL_FRICTION",
    "DriveParamsNotAppliedError",
    "PybulletResponse",
    "PybulletRobot",
    "tyre_friction",
]


class PybulletRobot(UncheckedPybulletRobot):
    """A spec'd robot in a pybullet world, driven through the drive chain.

    Parameters
    ----------
    spec : RobotSpec or str
        The robot (a spec, a shipped robot name or a spec file path).
    client : int, optional
        A pybullet client id to add the robot to (it must have gravity and a ground, e.g.
        :func:`robots.world.add_ground`). ``None`` creates an own ``DIRECT`` client with
        gravity and a generated ground plane (closed by :meth:`close`). The robot sets the
        client's fixed time step, solver iterations and pyramid friction, so robots sharing a
        client must use the same ``physics_hz``.
    params : DriveParams, optional
        Drive parameters; default ``spec.drive``.
    physics_hz : float
        Physics rate, Hz; :meth:`step` runs a whole number of physics steps. Sets the client's
        fixed time step.
    start_pose : tuple
        Initial (x [m], y [m], yaw [rad]) of base_link projected on the ground.

    Attributes
    ----------
    spec : RobotSpec
    client : int
        pybullet client id.
    body_id : int
        pybullet body id of the robot.
    time_s : float
        Simulated time since the last :meth:`reset`, s.

    Raises
    ------
    SpecError
        The spec fails :func:`robots.check.check_spec` (checked once per spec and process).
    """

    def _admit(self, spec: RobotSpec) -> None:
        ensure_spec_ok(spec)  # geometry + 1 s drive test, once per spec and process
