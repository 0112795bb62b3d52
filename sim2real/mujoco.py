r"""The identified robot in MuJoCo: the exported model, its drive controller and a replay engine.

:func:`robots.mjcf.mjcf_text` writes the MJCF model (bodies, wheel actuators, the axis
friction as tendon damping and frictionloss); this module drives it:

- :class:`MujocoDrive` is what MJCF cannot express: the command delay and timeout, the
  firmware clamp and acceleration limits, the wheel targets of a (v, w) command (the
  per-wheel speed cap scales both together), the PI loop's integral term and a skid steer's
  effective track (torque on the ``wheel_*_loop`` actuators), the motors' torque-speed line
  (``actuatorfrcrange`` of the wheel joints) and a direction-dependent Coulomb force
  (``frictionloss`` of the ``forward`` tendon). Call :meth:`MujocoDrive.command` with each
  (v, w) command and :meth:`MujocoDrive.apply` before each ``mj_step``;
- :class:`MujocoRobot` compiles the model once; :meth:`MujocoRobot.set_params` writes another
  parameter set into the compiled ``MjModel`` in place (the entries of
  :func:`robots.mjcf.mjcf_mapping`; no recompile: an ensemble member is a field edit) and
  :meth:`MujocoRobot.replay` drives a logged command sequence (``agree --engine mujoco``);
- a recording made with the wheels lifted off the ground (a base on a stand) replays on
  ``MujocoRobot(..., lifted=True)`` (``agree --engine mujoco-lifted``): the base is welded in
  the air with contacts off, the wheels spin free, and the reported (v, w) are the wheel
  encoders' body speeds on the effective track, :math:`v = r(\omega_l + \omega_r)/2`,
  :math:`w = r(\omega_r - \omega_l)/(\chi L)`. This is how the reduced engine reads such a
  log: it always links the wheels to the base through the effective track and loads them
  with the base's total mass and yaw inertia (fitted on the log, they absorb what drives the
  spinning wheels), so the lifted model puts that mass and inertia on the wheels as the
  armature of the ``forward`` and ``yaw`` tendons (less the wheels' own spin inertia; the two
  wheels are sibling branches, so MuJoCo's mass matrix keeps only each wheel's own share, and
  the two part for a few steps after a speed change). On the ground the exported model's
  tyres would scrub in every turn, which a lifted log never saw.

mujoco is an optional dependency (the ``[mujoco]`` extra): :func:`import_mujoco` says in one
sentence how to install it.

Examples
--------
>>> import numpy as np
>>> from robots.spec import load_spec
>>> robot = MujocoRobot(load_spec("turtlebot3_burger"))  # doctest: +SKIP
>>> cmd = (np.array([0.0]), np.array([0.2]), np.array([0.0]))  # stamps, v, w
>>> v, w = robot.replay(cmd, np.array([0.0, 0.4]))  # doctest: +SKIP
>>> round(float(v[-1]), 2)  # doctest: +SKIP
0.19
"""

from __future__ import annotations

import importlib
import itertools
import math
from types import ModuleType
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robots._jit import njit
from robots._kernel import (
    ZERO_TARGET_RADPS,
    pack_params,
    shape_command,
    starts_new_move,
    torque_limits,
)
from robots.mjcf import WHEELS, check_drive_kind, mjcf_mapping, mjcf_text, wheel_torque_cap_nm
from robots.params import DriveParams
from robots.reduced import delayed_step_average, simulate
from robots.spec import RobotSpec, lumped_base_inertia
from sim2real.errors import Sim2RealValueError

__all__ = ["INSTALL_HINT", "MujocoDrive", "MujocoRobot", "check_drive", "import_mujoco"]

FloatArray = NDArray[np.float64]
#: Logged commands: (stamps s, v m/s, w rad/s).
Commands = tuple[FloatArray, FloatArray, FloatArray]

#: How to install the optional MuJoCo dependency.
INSTALL_HINT = "pip install 'sim2real[mujoco]'"
_JOINTS = tuple(f"wheel_{s}_joint" for s in WHEELS)
#: A lifted base: welded to the world where it stands (:class:`MujocoRobot` ``lifted``).
_WELD_BASE = '  <equality><weld name="lifted" body1="base_link"/></equality>\n'


def import_mujoco() -> ModuleType:
    """The ``mujoco`` module, or one sentence saying how to install it.

    Raises
    ------
    Sim2RealValueError
        mujoco is not installed (the CLI prints the sentence and exits 2).
    """
    try:
        return importlib.import_module("mujoco")
    except ImportError:
        raise Sim2RealValueError(
            "the mujoco engine needs MuJoCo, which is not installed; install the [mujoco] "
            f"extra with {INSTALL_HINT} (or pip install 'mujoco>=4,<5')"
        ) from None


def _set_field(
    model: Any, kind: str, names: tuple[str, ...], array: str, column: int, value: float
) -> None:
    """Write one :class:`robots.mjcf.MjcfValue` into the compiled model (see its ``model``)."""
    mj = import_mujoco()
    objtype = getattr(mj.mjtObj, f"mjOBJ_{kind.upper()}")
    for name in names:
        row = mj.mj_name2id(model, objtype, name)
        if array.startswith("dof_"):
            row = int(model.jnt_dofadr[row])
        field = getattr(model, array)
        if array.endswith("range"):  # a symmetric limit; inf = none
            finite = math.isfinite(value)
            field[row] = (-value, value) if finite else (0.0, 0.0)
            getattr(model, array.replace("range", "limited"))[row] = finite
        elif field.ndim == 1:
            field[row] = value
        else:
            field[row, column] = value
            if array == "actuator_gainprm":  # a velocity actuator's bias is -kv qdot
                model.actuator_biasprm[row, 2] = -value


@njit(cache=True)
def _wheel_targets(
    u_v: FloatArray, u_w: FloatArray, ref_v: float, ref_w: float, dt: float, p: FloatArray
) -> FloatArray:  # pragma: no cover - compiled
    """(left, right) wheel targets of each delayed command, rad/s, and 1 where they start a new
    move (:func:`robots._kernel.starts_new_move`), else 0: one row a step."""
    out = np.empty((u_v.shape[0], 3))
    for k in range(u_v.shape[0]):
        ref_v0, ref_w0 = ref_v, ref_w
        ref_v, ref_w, wr, wl = shape_command(u_v[k], u_w[k], ref_v, ref_w, dt, p)
        out[k, 0] = wl
        out[k, 1] = wr
        out[k, 2] = 1.0 if starts_new_move(ref_v0, ref_w0, wr, wl, p) else 0.0
    return out


class MujocoDrive:
    """The drive chain's controller around the exported MJCF model (see the module docstring).

    Parameters
    ----------
    model : mujoco.MjModel
        A model written by :func:`robots.mjcf.mjcf_text` (any scene that includes it).
    spec : RobotSpec
        The robot.
    params : DriveParams
        The identified drive.
    lifted : bool
        The wheels spin in the air (:class:`MujocoRobot` ``lifted``): the loops read the body
        speeds from the wheels on the effective track, not from the (held) base.

    Examples
    --------
    >>> drive = MujocoDrive(model, spec, spec.drive)  # doctest: +SKIP
    >>> drive.command(data.time, 0.2, 0.0)  # doctest: +SKIP
    >>> for _ in range(240):  # doctest: +SKIP
    ...     drive.apply(model, data)
    ...     mujoco.mj_step(model, data)
    """

    def __init__(
        self, model: Any, spec: RobotSpec, params: DriveParams, *, lifted: bool = False
    ) -> None:
        self.spec = spec
        self.lifted = lifted
        self.dt_s = float(model.opt.timestep)
        mj = import_mujoco()
        self._wheel_dof = [
            int(model.jnt_dofadr[mj.mj_name2id(model, mj.mjtObj.mjOBJ_JOINT, j)]) for j in _JOINTS
        ]
        self._base_dof = int(model.jnt_dofadr[mj.mj_name2id(model, mj.mjtObj.mjOBJ_JOINT, "base")])
        self._base_body = mj.mj_name2id(model, mj.mjtObj.mjOBJ_BODY, "base_link")
        self._forward = mj.mj_name2id(model, mj.mjtObj.mjOBJ_TENDON, "forward")
        self._joint_ids = [mj.mj_name2id(model, mj.mjtObj.mjOBJ_JOINT, j) for j in _JOINTS]
        self._speed_act = [
            mj.mj_name2id(model, mj.mjtObj.mjOBJ_ACTUATOR, f"wheel_{s}_speed") for s in WHEELS
        ]
        self._loop_act = [
            mj.mj_name2id(model, mj.mjtObj.mjOBJ_ACTUATOR, f"wheel_{s}_loop") for s in WHEELS
        ]
        self.set_params(params)
        self.reset()

    def set_params(self, params: DriveParams) -> None:
        """Use ``params`` from the next step on (the model's fields: :meth:`MujocoRobot.set_params`)."""
        check_drive_kind(self.spec, params)
        self.params = params
        self._packed = pack_params(params, self.spec.geometry)
        self._torque_cap = wheel_torque_cap_nm(self.spec, params)
        d = params
        line = math.isfinite(d.wheel_stall_torque_nm) and math.isfinite(d.wheel_no_load_speed_radps)
        self._line = line
        self._asymmetric = d.coulomb_v_fwd_n != d.coulomb_v_bwd_n
        self._loop = d.speed_loop_ki_per_s > 0.0 or d.track_factor != 1.0
        #: True when a step needs the measured state (else the targets alone drive it)
        self.feedback = self._line or self._asymmetric or self._loop

    def reset(self, v: float = 0.0, w: float = 0.0) -> None:
        """Clear the command history, the smoother's reference (to (v, w)) and the integrators."""
        self.ref_v, self.ref_w = float(v), float(w)
        self.integ = [0.0, 0.0]
        self._hist_t: list[float] = []
        self._hist_v: list[float] = []
        self._hist_w: list[float] = []

    def command(self, t_s: float, v: float, w: float) -> None:
        """A (v [m/s], w [rad/s]) command stamped ``t_s`` (the model's clock, ``data.time``)."""
        if not (math.isfinite(v) and math.isfinite(w) and math.isfinite(t_s)):
            raise Sim2RealValueError(f"a command must be finite, got ({v!r}, {w!r}) at {t_s!r}")
        horizon = t_s - self.params.delay_s - 1.0  # keep what can still act (1 s of margin)
        while len(self._hist_t) > 1 and self._hist_t[1] < horizon:
            del self._hist_t[0], self._hist_v[0], self._hist_w[0]
        self._hist_t.append(float(t_s))
        self._hist_v.append(float(v))
        self._hist_w.append(float(w))

    def targets(self, u_v: float, u_w: float) -> tuple[float, float]:
        """(left, right) wheel speed targets of the delayed command (u_v, u_w), rad/s.

        Advances the smoother's reference by one step (clamp, rate limits, wheel cap); a new
        move (``command_starts_new_move``, :func:`robots._kernel.starts_new_move`) clears the
        integrators.
        """
        ref_v0, ref_w0 = self.ref_v, self.ref_w
        self.ref_v, self.ref_w, wr, wl = shape_command(
            u_v, u_w, ref_v0, ref_w0, self.dt_s, self._packed
        )
        if starts_new_move(ref_v0, ref_w0, wr, wl, self._packed):
            self.integ = [0.0, 0.0]
        return wl, wr

    def _delayed(self, t0_s: float, n: int) -> tuple[FloatArray, FloatArray]:
        """The delayed commands of ``n`` steps from ``t0_s`` (zero before the first)."""
        if not self._hist_t:
            return np.zeros(n), np.zeros(n)
        t = np.array(self._hist_t)
        grid = t0_s + self.dt_s * np.arange(n, dtype=np.float64)
        kw = {"delay_s": self.params.delay_s, "timeout_s": self.params.cmd_timeout_s}
        return (
            delayed_step_average(t, np.array(self._hist_v), grid, self.dt_s, **kw),
            delayed_step_average(t, np.array(self._hist_w), grid, self.dt_s, **kw),
        )

    def apply(self, model: Any, data: Any) -> None:
        """Set ``data.ctrl`` (and the drive's model fields) for the step from ``data.time``."""
        u_v, u_w = self._delayed(float(data.time), 1)
        self.control(model, data, *self.targets(float(u_v[0]), float(u_w[0])))

    def advance(self, model: Any, data: Any, steps: int) -> None:
        """``steps`` physics steps (:meth:`apply`, then ``mj_step``, each), the delayed
        commands of all of them computed at once.

        Examples
        --------
        >>> drive.command(data.time, 0.2, 0.0)  # doctest: +SKIP
        >>> drive.advance(model, data, 24)  # 0.1 s at 240 Hz  # doctest: +SKIP
        """
        mj = import_mujoco()
        u_v, u_w = self._delayed(float(data.time), steps)
        for a, b in zip(u_v.tolist(), u_w.tolist(), strict=True):
            self.control(model, data, *self.targets(a, b))
            mj.mj_step(model, data)

    def body_speeds(self, data: Any) -> tuple[float, float]:
        """(v [m/s] along the heading, w [rad/s]) of the base; lifted: the wheels' encoder
        speeds on the effective track (see the module docstring)."""
        qvel = data.qvel
        if self.lifted:
            wl, wr = float(qvel[self._wheel_dof[0]]), float(qvel[self._wheel_dof[1]])
            r = self.spec.wheels.radius_m
            track = self.spec.wheels.separation_m * self.params.track_factor
            return 0.5 * r * (wl + wr), r * (wr - wl) / track
        b = self._base_dof
        xmat = data.xmat[self._base_body]
        return float(xmat[0] * qvel[b] + xmat[3] * qvel[b + 1]), float(qvel[b + 5])

    def control(self, model: Any, data: Any, wl_ref: float, wr_ref: float) -> None:
        """Set the actuators for wheel targets (``wl_ref``, ``wr_ref``) rad/s, one step."""
        ctrl = data.ctrl
        ctrl[self._speed_act[0]] = wl_ref
        ctrl[self._speed_act[1]] = wr_ref
        if not self.feedback:
            return
        qvel = data.qvel
        p, d = self._packed, self.params
        r, sep = self.spec.wheels.radius_m, self.spec.wheels.separation_m
        v, w = self.body_speeds(data)
        if self._asymmetric:
            tendon_v = data.ten_velocity[self._forward]
            push = tendon_v if tendon_v != 0.0 else wl_ref + wr_ref
            model.tendon_frictionloss[self._forward] = (
                d.coulomb_v_fwd_n if push >= 0.0 else d.coulomb_v_bwd_n
            )
        half_e = 0.5 * sep * d.track_factor
        for i, (ref, side) in enumerate(((wl_ref, -1.0), (wr_ref, 1.0))):
            omega = float(qvel[self._wheel_dof[i]])
            lo, hi = -self._torque_cap, self._torque_cap
            if self._line:
                lo, hi = torque_limits(omega, self._torque_cap, p[19], p[20])
                model.jnt_actfrcrange[self._joint_ids[i]] = (lo, hi)
                model.jnt_actfrclimited[self._joint_ids[i]] = 1
            if not self._loop:
                continue
            omega_model = (v + side * w * half_e) / r
            err = ref - omega_model
            if abs(ref) < ZERO_TARGET_RADPS:
                self.integ[i] = 0.0
            extra = d.motor_gain_nms_per_rad * (
                d.speed_loop_ki_per_s * self.integ[i] + omega - omega_model
            )
            total = d.motor_gain_nms_per_rad * (ref - omega) + extra
            if not ((total >= hi and err > 0.0) or (total <= lo and err < 0.0)):
                self.integ[i] += self.dt_s * err
            ctrl[self._loop_act[i]] = extra


class MujocoRobot:
    """The exported robot compiled once, with its :class:`MujocoDrive` (see the module).

    Parameters
    ----------
    spec : RobotSpec
        The robot.
    params : DriveParams, optional
        The drive; the spec's defaults when omitted.
    xml : str, optional
        The model's MJCF text when it is at hand (default: :func:`robots.mjcf.mjcf_text`).
    lifted : bool
        Replay a recording made with the wheels off the ground (see the module docstring):
        the base welded in place, contacts off, (v, w) from the wheel speeds.

    Examples
    --------
    >>> from robots.spec import load_spec
    >>> robot = MujocoRobot(load_spec("turtlebot2"))  # doctest: +SKIP
    >>> robot.set_params(robot.spec.drive.replace(added_mass_kg=1.0))  # doctest: +SKIP
    >>> float(robot.model.body("base_link").mass[0]) > 3.0  # doctest: +SKIP
    True
    """

    def __init__(
        self,
        spec: RobotSpec,
        params: DriveParams | None = None,
        *,
        xml: str | None = None,
        lifted: bool = False,
    ) -> None:
        self._mj = import_mujoco()
        self.spec = spec
        self.lifted = lifted
        p = spec.drive if params is None else params
        text = mjcf_text(spec, p) if xml is None else xml
        if lifted:  # held where it stands: the weld's relative pose is the one at qpos0
            text = text.replace("</mujoco>", _WELD_BASE + "</mujoco>", 1)
        self.model = self._mj.MjModel.from_xml_string(text)
        if lifted:
            self.model.opt.disableflags |= self._mj.mjtDisableBit.mjDSBL_CONTACT
        self.data = self._mj.MjData(self.model)
        self.drive = MujocoDrive(self.model, spec, p, lifted=lifted)
        self._base_body = self.model.body("base_link").id
        self.set_params(p)

    @property
    def params(self) -> DriveParams:
        """The drive parameters in use."""
        return self.drive.params

    def set_params(self, params: DriveParams) -> None:
        """Write ``params`` into the compiled model in place (no recompile) and the drive."""
        check_drive_kind(self.spec, params)
        for entry in mjcf_mapping(self.spec, params):
            if entry.model is not None:
                kind, names, attr, index = entry.model
                _set_field(self.model, kind, names, attr, index, entry.value)
        # roll and pitch as robots.mjcf writes them (A + B >= C with the new yaw inertia)
        inertia = self.model.body_inertia[self._base_body]
        inertia[:2] = np.maximum(lumped_base_inertia(self.spec)[:2], 0.5 * inertia[2])
        if self.lifted:
            self._load_wheels(params)
        self._mj.mj_setConst(self.model, self.data)
        self.drive.set_params(params)

    def _load_wheels(self, params: DriveParams) -> None:
        """Lifted: the base's total mass and yaw inertia (as the reduced engine counts them,
        less the wheels' spin) as the armature of the ``forward`` and ``yaw`` tendons."""
        g, w, chi = self.spec.geometry, self.spec.wheels, params.track_factor
        spin = w.spin_inertia_kgm2 / w.radius_m**2  # apparent mass of one wheel's spin, kg
        mass = params.total_mass_kg(g) - 2.0 * spin
        # the drive model turns the base by the wheel forces at the geometric half-track L/2
        # while w = r (w_r - w_l) / (chi L): a wheel-torque difference 2 r^2 I / (chi L^2)
        # per unit of (w_r - w_l)', which the yaw tendon (rate r (w_r - w_l) / L) gives
        # with armature I / chi; the wheels' own spin gives J, i.e. I = spin chi L^2 / 2
        yaw = params.total_yaw_inertia_kgm2(g) - 0.5 * spin * chi * w.separation_m**2
        armature = self.model.tendon_armature
        armature[self.model.tendon("forward").id] = max(mass, 0.0)
        armature[self.model.tendon("yaw").id] = max(yaw, 0.0) / chi

    def reset(self, v: float = 0.0, w: float = 0.0) -> None:
        """Put the robot at the origin on the ground moving at (v, w); clear the drive."""
        mj, m, d = self._mj, self.model, self.data
        mj.mj_resetData(m, d)
        d.qpos[2] = self.spec.base_link_height_m
        r, half = self.spec.wheels.radius_m, 0.5 * self.spec.wheels.separation_m
        d.qvel[0], d.qvel[5] = v, w
        dofs = self.drive._wheel_dof
        d.qvel[dofs[0]], d.qvel[dofs[1]] = (v - w * half) / r, (v + w * half) / r
        mj.mj_forward(m, d)
        self.drive.reset(v, w)

    def velocity(self) -> tuple[float, float]:
        """True (v [m/s] along the heading, w [rad/s] about the vertical) of the base; lifted:
        the wheels' encoder speeds (:meth:`MujocoDrive.body_speeds`)."""
        if self.lifted:
            return self.drive.body_speeds(self.data)
        d, b = self.data, self._base_body
        xmat = d.xmat[b]
        return (
            float(xmat[0] * d.qvel[0] + xmat[3] * d.qvel[1]),
            float(d.cvel[b][2]),
        )

    def replay(
        self, cmd: Commands, t_out_s: FloatArray, start: tuple[float, float] = (0.0, 0.0)
    ) -> tuple[FloatArray, FloatArray]:
        """Drive logged commands ``cmd`` = (times s, v m/s, w rad/s) from the base moving at
        ``start`` = (v, w); returns (v, w) at ``t_out_s``.

        As :func:`robots.reduced.simulate`: the run starts at ``t_out_s[0]``, each physics step
        gets the delayed zero-order-hold command averaged over it (with the timeout), and the
        base velocity is interpolated linearly at ``t_out_s``. Steps whose targets do not
        change run in one ``mj_step`` call unless the drive needs the measured state
        (:attr:`MujocoDrive.feedback`).
        """
        cmd_t_s, cmd_v, cmd_w = cmd
        v0, w0 = start
        mj, m, d, drive = self._mj, self.model, self.data, self.drive
        dt, p = drive.dt_s, drive.params
        t_out = np.asarray(t_out_s, dtype=np.float64)
        t0 = float(t_out[0])
        n = max(1, math.ceil((float(t_out[-1]) - t0) / dt))
        grid = t0 + dt * np.arange(n + 1, dtype=np.float64)
        kw = {"delay_s": p.delay_s, "timeout_s": p.cmd_timeout_s}
        u_v = delayed_step_average(cmd_t_s, cmd_v, grid[:-1], dt, **kw)
        u_w = delayed_step_average(cmd_t_s, cmd_w, grid[:-1], dt, **kw)
        self.reset(v0, w0)
        below = np.clip(np.searchsorted(grid, t_out, side="right") - 1, 0, max(n - 1, 0))
        sampled = np.unique(np.concatenate((below, below + 1)))
        record = np.zeros(n + 1, dtype=bool)
        record[sampled] = True
        record[0] = True  # the start state is the first row
        targets = _wheel_targets(u_v, u_w, v0, w0, dt, drive._packed)
        # a run of steps starts where the targets change (beyond rounding) or a sample is due
        begins = np.ones(n + 1, dtype=bool)
        if not drive.feedback:
            begins[1:n] = np.any(np.abs(np.diff(targets[:, :2], axis=0)) > 1e-12, axis=1)
        begins |= record
        bounds = np.flatnonzero(begins).tolist()
        tl = targets.tolist()
        rows: list[tuple[float, float]] = [self.velocity()]
        for a, b in itertools.pairwise(bounds):
            if tl[a][2]:  # a new move: the loops start again (a feedback drive: one step a run)
                drive.integ = [0.0, 0.0]
            drive.control(m, d, tl[a][0], tl[a][1])
            mj.mj_step(m, d, b - a)
            if record[b]:
                rows.append(self.velocity())
        steps = np.flatnonzero(record)
        rec = np.array(rows)
        at = grid[steps]
        return np.interp(t_out, at, rec[:, 0]), np.interp(t_out, at, rec[:, 1])


#: The drive check's tolerance: the MuJoCo robot's speed within this fraction of the drive
#: model's (:func:`robots.reduced.simulate`) on the same command.
CHECK_TOLERANCE = 0.2


def check_drive(spec: RobotSpec, params: DriveParams, *, xml: str | None = None) -> str:
    """The ``robots check`` drive test in MuJoCo: forward, turn, stop, against the drive model.

    A forward command (half the top speed, at 10 Hz) for 1.5 s, then 0; a turn command (half
    the top yaw rate) the same way. The MuJoCo robot must move the commanded way, within
    :data:`CHECK_TOLERANCE` of the drive model's speed at 1.5 s, and stop (below 5 % of the
    command) 1.5 s after the last command.

    Returns
    -------
    str
        The measured speeds, e.g. ``'forward 0.110 m/s, turn 1.42 rad/s, stops'``.

    Raises
    ------
    Sim2RealValueError
        A check fails (the sentence names it and the numbers).

    Examples
    --------
    >>> from robots.spec import load_spec
    >>> spec = load_spec("turtlebot3_burger")
    >>> check_drive(spec, spec.drive)  # doctest: +SKIP
    'forward 0.110 m/s, turn 1.42 rad/s, stops'
    """
    robot = MujocoRobot(spec, params, xml=xml)
    t_out = np.array([0.0, 1.5, 3.0 + params.delay_s])
    cmd_t = np.arange(0.0, 1.55, 0.1)  # a 10 Hz stream (a base's command timeout), then 0
    found = []
    for axis, unit, top in (
        ("forward", "m/s", spec.max_v_mps),
        ("turn", "rad/s", spec.max_w_radps),
    ):
        cmd = np.where(cmd_t < 1.45, 0.5 * top, 0.0)
        zero = np.zeros_like(cmd)
        cmd_v, cmd_w = (cmd, zero) if axis == "forward" else (zero, cmd)
        v, w = robot.replay((cmd_t, cmd_v, cmd_w), t_out)
        model = simulate(
            params,
            spec.geometry,
            cmd_t_s=cmd_t,
            cmd_v=cmd_v,
            cmd_w=cmd_w,
            t_out_s=t_out,
            python=None,
        )
        got, want = (v, model.v) if axis == "forward" else (w, model.w)
        if not (got[1] > 0.0 and abs(got[1] - want[1]) <= CHECK_TOLERANCE * abs(want[1])):
            raise Sim2RealValueError(
                f"MuJoCo drive check of robot '{spec.name}' failed: a {axis} command of "
                f"{cmd[0]:.3g} {unit} gives {got[1]:.3g} {unit} after 1.5 s where the drive "
                f"model gives {want[1]:.3g} {unit}; check the spec's wheels and casters"
            )
        if abs(got[2]) > 0.05 * cmd[0]:
            raise Sim2RealValueError(
                f"MuJoCo drive check of robot '{spec.name}' failed: 1.5 s after a {axis} "
                f"command ends the base still moves at {got[2]:.3g} {unit}; check the spec"
            )
        found.append(f"{axis} {got[1]:.3g} {unit}")
    return ", ".join(found) + ", stops"
