"""An excitation plan: the command script to record so that a fit identifies the drive.

A go-to-goal or teleop session excites what its task needs: a few speeds, gentle turns, rarely
a limit. :func:`plan_excitation` writes a script for a base from its spec alone, made of
blocks that each excite named parameters of :class:`robots.params.DriveParams`:

- **v steps** and **w steps**: held steps of several sizes, up to 110 % of the speed limits
  (the firmware clamps: the limits are reached), each followed by a stop: delay, response
  time constants, speed-loop integral action, torque and acceleration limits, speed limits;
- **ramps**: slow ramps forward and backward: Coulomb friction each way, apart from viscous;
- **speed levels** (in a cycle the script holds whole): steps of half a level up and down
  around held speeds and turn rates (half and 0.7 of the limits), no stop between: the wheel
  loops' integrators stay loaded, so the transients carry the friction apart from the loops'
  gains;
- **turns while driving**: arcs and weaves at several speeds and turn rates, the fastest with
  the outer wheel's target above the wheel-speed cap, reversed at once (the outer wheel from
  its cap to minus its cap: the largest torque any command within the limits asks): the cap,
  the coupling of the axes and the torque cap.

Every moving block is driven out and back (the same commands reversed in order and sign), so
the ideal path returns to its start and stays within a square of side ``area_m``. The script is
deterministic: the same spec and duration give the same commands. Velocity data fix each axis's
response, not the split between motor gain and mass (:mod:`sysid.fit`): no plan identifies
``motor_gain_nms_per_rad``, ``added_mass_kg`` and ``added_yaw_inertia_kgm2`` apart. Nor does
any plan identify a wheel torque cap that no command within the limits makes a wheel reach
(:func:`unreachable`: behind a velocity smoother, the largest ask may stay far below it).
:func:`information_bound` computes the best case one session of a length could reach for
each smooth parameter (the Fisher information of the plan and of each of its block kinds
alone, at a stated noise and command jitter); :func:`beyond_session` names what even that
leaves above half its prior sd.

Examples
--------
>>> from robots.spec import load_spec
>>> plan = plan_excitation(load_spec("turtlebot3_burger"), 90.0)
>>> plan.t_s.size, round(float(abs(plan.v_mps).max()), 3)
(900, 0.242)
>>> "wheel_speed_max_radps" in plan.identifies()
True
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from robots.arrays import FloatArray
from robots.params import SCHEMA, coords_to_values
from robots.reduced import DEFAULT_DT_S, simulate
from sysid._coords import Mapper
from sysid._logs import LogArrays
from sysid._needs import limit_needs
from sysid._problem import Problem
from sysid.errors import SysidValueError

__all__ = [
    "BEYOND_SD_RATIO",
    "LIMITS",
    "REACH_SD",
    "REFERENCE_JITTER_S",
    "REFERENCE_NOISE",
    "ExcitationPlan",
    "InformationBound",
    "PlanBlock",
    "TorqueReach",
    "beyond_session",
    "information_bound",
    "plan_excitation",
    "torque_cap_reach",
    "unreachable",
    "weakly_identified",
]


#: Commands go this far beyond the speed limits, so that the clamps act.
OVERDRIVE = 1.1
#: The fastest arcs ask the outer wheel for this multiple of the wheel-speed cap.
WHEEL_OVERDRIVE = 1.2
#: Speed levels (share of the speed limit, by cycle), the steps around them (share of the
#: level) and how long each is held, s.
LEVELS = (0.5, 0.7)
LEVEL_STEPS = (0.0, 0.5, 0.0, -0.5, 0.0)
LEVEL_HOLD_S = 0.6
#: The mass-gain direction: velocity data identify ``T = m / k``, not ``m`` and ``k`` apart.
MASS_GAIN = ("motor_gain_nms_per_rad", "added_mass_kg", "added_yaw_inertia_kgm2")

#: A torque cap whose prior centre lies more than this many combined prior sd (cap and total
#: mass or inertia, in log) above the largest torque any command within the limits asks is
#: out of reach (:func:`torque_cap_reach`): the priors give it less than a 5 % chance
#: (one-sided) of lying below the ask.
REACH_SD = 1.645

#: Behind PI wheel loops, a friction term whose prior sd is below this share of the loop's
#: proportional gain changes the transients' damping too little to be told, in one session,
#: from the commands' timing jitter at unsmoothed steps and the per-wheel friction the drive
#: model sums per axis (:func:`weakly_identified`; docs/transfer.md).
WEAK_FRICTION_SHARE = 0.05
#: The information bound's odometry: white noise of v and w (m/s, rad/s, per 30 Hz sample)
#: and the sd of each command's arrival time about its logged time, s (a ROS transport).
REFERENCE_NOISE = (0.004, 0.02)
REFERENCE_JITTER_S = 0.01
#: A parameter whose best-case posterior sd over prior sd (:func:`information_bound`) is
#: above this is beyond one session of the length (:func:`beyond_session`).
BEYOND_SD_RATIO = 0.5
#: Limits: a limit binds (and the data bound it sharply) or it does not (and they bound it from
#: one side only), so the information at one point says nothing of it (the torque cap's
#: reach is :func:`torque_cap_reach`'s).
LIMITS = (
    "speed_lim_v_mps",
    "speed_lim_w_radps",
    "accel_lim_v_mps2",
    "accel_lim_w_radps2",
    "wheel_speed_max_radps",
    "wheel_torque_max_nm",
    "wheel_stall_torque_nm",
    "wheel_no_load_speed_radps",
)
#: Forward-and-back step of each parameter in the bound's Jacobian, share of its prior sd.
_BOUND_STEP = 0.1
#: Odometry rate of the bound's log, Hz.
_BOUND_ODOM_HZ = 30.0
#: Block kind -> the DriveParams fields it is designed to identify.
_EXCITES: dict[str, tuple[str, ...]] = {
    "v steps": (
        "delay_s",
        "speed_lim_v_mps",
        "accel_lim_v_mps2",
        "wheel_torque_max_nm",
        "speed_loop_ki_per_s",
        "viscous_v_ns_per_m",
        "wheel_stall_torque_nm",
        "wheel_no_load_speed_radps",
        *MASS_GAIN[:2],
    ),
    "w steps": (
        "delay_s",
        "speed_lim_w_radps",
        "accel_lim_w_radps2",
        "coulomb_w_nm",
        "viscous_w_nms_per_rad",
        "motor_gain_nms_per_rad",
        "added_yaw_inertia_kgm2",
    ),
    "speed levels": (
        "speed_loop_ki_per_s",
        "coulomb_v_fwd_n",
        "coulomb_v_bwd_n",
        "coulomb_w_nm",
        "viscous_v_ns_per_m",
        "viscous_w_nms_per_rad",
    ),
    "ramps": ("coulomb_v_fwd_n", "coulomb_v_bwd_n", "viscous_v_ns_per_m"),
    "turns while driving": (
        "wheel_speed_max_radps",
        "wheel_torque_max_nm",
        "track_factor",
        "driver_track_factor",
    ),
}


@dataclass(frozen=True, kw_only=True)
class PlanBlock:
    """One block of a plan.

    Attributes
    ----------
    kind : str
        ``"v steps"``, ``"w steps"``, ``"ramps"`` or ``"turns while driving"``.
    start_s, end_s : float
        Its span in the script, s.
    identifies : tuple of str
        The DriveParams fields it is designed to identify.
    """

    kind: str
    start_s: float
    end_s: float
    identifies: tuple[str, ...]


@dataclass(frozen=True, kw_only=True)
class ExcitationPlan:
    """A command script (see the module docstring).

    Attributes
    ----------
    robot : str
        The spec the plan was designed from.
    t_s, v_mps, w_radps : ndarray
        Commands republished at ``rate_hz`` from t = 0, s, m/s, rad/s.
    rate_hz : float
        Publishing rate, Hz.
    duration_s : float
        Length of the script, s.
    blocks : tuple of PlanBlock
        The blocks, in order.
    limits : dict
        The limits designed to: ``v_mps``, ``w_radps``, ``wheel_radps`` (spec values).
    extent_m : float
        Largest distance of the ideal (perfectly tracked) path from its start, m.
    weak : dict
        DriveParams field -> why one session of the plan may leave it near its prior, from the
        spec (:func:`weakly_identified`); fields known exactly (prior sd 0) are left out of
        :meth:`identifies`.
    unreachable : dict
        DriveParams field -> why no command within the base's limits can identify it, from
        the spec (:func:`unreachable`); left out of :meth:`identifies`.
    """

    robot: str
    t_s: FloatArray
    v_mps: FloatArray
    w_radps: FloatArray
    rate_hz: float
    duration_s: float
    blocks: tuple[PlanBlock, ...]
    limits: dict[str, float]
    extent_m: float
    weak: dict[str, str]
    unreachable: dict[str, str]

    def identifies(self) -> dict[str, tuple[str, ...]]:
        """DriveParams field -> the kinds of block that excite it (in plan order), for the
        fields with a prior to inform and within reach of the commands (not in
        :attr:`unreachable`); :attr:`weak` says which of them one session may leave near their
        priors, and why."""
        out: dict[str, list[str]] = {}
        for block in self.blocks:
            for name in block.identifies:
                if name in self.unreachable:
                    continue
                kinds = out.setdefault(name, [])
                if block.kind not in kinds:
                    kinds.append(block.kind)
        return {name: tuple(kinds) for name, kinds in out.items()}


@dataclass(frozen=True, kw_only=True)
class TorqueReach:
    """The largest wheel torque commands within a base's limits ask, against its torque cap.

    Attributes
    ----------
    ask_nm : float
        Largest torque of one wheel, N m, over the command of :attr:`by`, at the prior centre.
    cap_nm : float
        The cap's prior centre, N m.
    margin_sd : float
        ``ln(cap_nm / ask_nm)`` over the combined prior sd of the cap and the total mass or
        yaw inertia (the ask scales with them; the cap does not).
    by : str
        The command that asks the most.
    """

    ask_nm: float
    cap_nm: float
    margin_sd: float
    by: str

    @property
    def reachable(self) -> bool:
        """False when the cap lies more than :data:`REACH_SD` combined sd above the ask."""
        return self.margin_sd <= REACH_SD


@dataclass(frozen=True, kw_only=True)
class InformationBound:
    """The best a session of one length can inform each smooth drive parameter.

    Attributes
    ----------
    duration_s : float
        The session's length, s.
    noise : tuple of float
        White noise of the odometry's v and w, m/s and rad/s per 30 Hz sample.
    jitter_s : float
        Sd of each command's arrival time about its logged time, s.
    sd_ratio : dict
        DriveParams field -> the least posterior sd over prior sd of the scripts tried (the
        plan and each of its block kinds alone for the whole length).
    by : dict
        DriveParams field -> the script that informs it best.
    """

    duration_s: float
    noise: tuple[float, float]
    jitter_s: float
    sd_ratio: dict[str, float]
    by: dict[str, str]


class _Script:
    """Commands at a fixed rate, built block by block."""

    def __init__(self, rate_hz: float) -> None:
        self.hz = rate_hz
        self.rows: list[tuple[float, float]] = []

    def hold(self, v: float, w: float, seconds: float) -> list[tuple[float, float]]:
        return [(v, w)] * max(1, round(seconds * self.hz))

    def ramp(self, v0: float, v1: float, seconds: float) -> list[tuple[float, float]]:
        n = max(2, round(seconds * self.hz))
        return [(float(v), 0.0) for v in np.linspace(v0, v1, n)]

    def out_and_back(
        self, leg: list[tuple[float, float]], rest_s: float, *, at_once: bool = False
    ) -> None:
        """``leg``, a rest (none when ``at_once``: a reversal), the same commands reversed in
        order and sign, a rest."""
        back = [(-v, -w) for v, w in reversed(leg)]
        mid = [] if at_once else self.hold(0.0, 0.0, rest_s)
        self.rows += leg + mid + back + self.hold(0.0, 0.0, rest_s)


def _check(spec: Any, duration_s: Any, rate_hz: Any, area_m: Any) -> None:
    for name, value, low in (("duration_s", duration_s, 10.0), ("rate_hz", rate_hz, 1.0)):
        if isinstance(value, bool) or not (isinstance(value, int | float) and value >= low):
            raise SysidValueError(
                f"{name} must be a number >= {low:g}, got {value!r}; a plan needs room for "
                "its blocks"
                if name == "duration_s"
                else f"{name} must be a number >= {low:g} Hz, got {value!r}"
            )
    if isinstance(area_m, bool) or not (isinstance(area_m, int | float) and area_m >= 0.5):
        raise SysidValueError(
            f"area_m must be a number >= 0.5 (side of the free floor square, m), got {area_m!r}"
        )
    if not hasattr(spec, "drive") or not hasattr(spec, "geometry"):
        raise SysidValueError(
            f"spec must be a robots.spec.RobotSpec, got {type(spec).__name__}; load one with "
            "robots.spec.load_spec(name)"
        )


def _levels(script: _Script, k: int, lim: dict[str, float]) -> None:
    """Steps of half a level up and down around a held level, each axis out and back."""
    share = LEVELS[k % len(LEVELS)]
    for axis in ("v", "w"):
        level = share * lim[f"{axis}_mps" if axis == "v" else "w_radps"]
        if axis == "v":  # the leg's path stays within a quarter of the floor's side
            level = min(level, 0.25 * lim["area_m"] / (len(LEVEL_STEPS) * LEVEL_HOLD_S))
        leg = []
        for a in LEVEL_STEPS:
            x = level * (1.0 + a)
            leg += (
                script.hold(x, 0.0, LEVEL_HOLD_S)
                if axis == "v"
                else script.hold(0.0, x, LEVEL_HOLD_S)
            )
        script.out_and_back(leg, 0.6)


def _cycle(
    script: _Script, k: int, lim: dict[str, float], hold_s: float, *, levels: bool
) -> list[PlanBlock]:
    """Cycle ``k`` of the blocks (sizes vary from cycle to cycle); the speed levels only when
    ``levels``."""
    v, w, half_track = lim["v_mps"], lim["w_radps"], lim["half_track_m"]
    sizes_v = [(0.35, OVERDRIVE, 0.7, 0.15), (0.55, 0.9, OVERDRIVE, 0.25)][k % 2]
    sizes_w = [(0.3, OVERDRIVE, 0.6, 0.06), (0.45, 0.8, OVERDRIVE, 0.1)][k % 2]
    blocks = []

    def block(kind: str, start: int) -> None:
        hz = script.hz
        blocks.append(
            PlanBlock(
                kind=kind,
                start_s=start / hz,
                end_s=len(script.rows) / hz,
                identifies=_EXCITES[kind],
            )
        )

    start = len(script.rows)
    for a in sizes_v:
        script.out_and_back(script.hold(a * v, 0.0, hold_s), 0.8)
    # a reversal at the limit: twice the step, the torque cap acts over the whole speed range
    script.rows += script.hold(OVERDRIVE * v, 0.0, hold_s) + script.hold(
        -OVERDRIVE * v, 0.0, hold_s
    )
    script.rows += script.hold(0.0, 0.0, 0.8)
    block("v steps", start)
    start = len(script.rows)
    for b in sizes_w:
        leg = script.hold(0.0, b * w, lim["hold_w_s"])
        script.rows += leg + script.hold(0.0, 0.0, 0.6) + [(0.0, -x) for _, x in leg]
        script.rows += script.hold(0.0, 0.0, 0.6)
    turn = lim["hold_w_s"]
    script.rows += script.hold(0.0, OVERDRIVE * w, turn) + script.hold(0.0, -OVERDRIVE * w, turn)
    script.rows += script.hold(0.0, 0.0, 0.6)
    block("w steps", start)
    if levels:
        start = len(script.rows)
        _levels(script, k, lim)
        block("speed levels", start)
    start = len(script.rows)
    ramp_s = min(3.0, 2.0 * hold_s)
    script.out_and_back(script.ramp(0.0, v, ramp_s) + script.ramp(v, 0.0, ramp_s), 0.6)
    block("ramps", start)
    start = len(script.rows)
    # the outer wheel asks WHEEL_OVERDRIVE x its cap: (v + w h) / r = 1.2 cap
    w_cap = (WHEEL_OVERDRIVE * lim["wheel_mps"] - v) / half_track
    w_arc = min(max(w_cap, 0.3 * w), OVERDRIVE * w)
    sign = 1.0 if k % 2 == 0 else -1.0
    # reversed at once: the outer wheel from its cap to minus its cap, the largest torque ask
    script.out_and_back(script.hold(v, sign * w_arc, 0.6 * hold_s + 0.6), 0.6, at_once=True)
    weave = script.hold(0.6 * v, 0.5 * w, 1.0) + script.hold(0.6 * v, -0.5 * w, 1.0)
    script.out_and_back(weave, 0.6)
    block("turns while driving", start)
    return blocks


def _centre(spec: Any) -> Any:
    """The drive parameters at the priors' centres, with no torque cap and no torque-speed
    line: the wheel loops get whatever torque they ask."""
    centre = {name: p.nominal for name, p in spec.priors.items() if name in SCHEMA}
    free = dict.fromkeys(
        ("wheel_torque_max_nm", "wheel_stall_torque_nm", "wheel_no_load_speed_radps"), math.inf
    )
    return spec.drive.replace(**(centre | free))


def torque_cap_reach(spec: Any) -> TorqueReach | None:
    """How close commands within ``spec``'s limits bring a wheel's torque to its cap.

    The drive model at the priors' centres, with the cap and the torque-speed line removed,
    runs the reversals that ask the wheels the most: forward speed from +110 % to -110 % of
    its limit, yaw rate likewise, and an arc whose outer wheel is at the wheel-speed cap
    reversed in v and w at once. The wheel torque is the base dynamics' at the responses
    (:func:`sysid._needs.limit_needs`: mass and inertia times the accelerations plus the
    friction). A velocity smoother bounds the accelerations; without one each reversal is a
    step into the loops. ``None`` when the cap is known exactly or infinite.

    Examples
    --------
    >>> from robots.spec import load_spec
    >>> reach = torque_cap_reach(load_spec("turtlebot2"))
    >>> reach.reachable, reach.by
    (False, 'an arc at the wheel-speed cap reversed')
    """
    prior = spec.priors["wheel_torque_max_nm"]
    if prior.sd == 0 or not math.isfinite(prior.nominal):
        return None
    drive, geo = spec.drive, spec.geometry
    params = _centre(spec)
    v = OVERDRIVE * min(drive.speed_lim_v_mps, spec.max_v_mps)
    w = OVERDRIVE * min(drive.speed_lim_w_radps, spec.max_w_radps)
    wheel = params.wheel_speed_max_radps
    half = 0.5 * geo.wheel_separation_m
    w_arc = max(wheel * geo.wheel_radius_m - v / OVERDRIVE, 0.0) / half
    settle = 1.5 + max(2.0 * v / drive.accel_lim_v_mps2, 2.0 * w / drive.accel_lim_w_radps2)
    t_out = np.arange(0.0, 2.0 * settle, 1e-3)
    t_cmd = np.arange(0.0, 2.0 * settle, 0.1)
    best = (0.0, "")
    for by, cv, cw in (
        ("a reversal of v at its limit", v, 0.0),
        ("a reversal of w at its limit", 0.0, w),
        ("an arc at the wheel-speed cap reversed", v / OVERDRIVE, w_arc),
    ):
        sign = np.where(t_cmd < settle, 1.0, -1.0)  # republished at 10 Hz (the timeout)
        out = simulate(
            params, geo, cmd_t_s=t_cmd, cmd_v=cv * sign, cmd_w=cw * sign, t_out_s=t_out,
            python=None,
        )  # fmt: skip
        late = t_out > 0.5 * settle  # the reversal, from a settled start
        ask = limit_needs([t_out[late]], [out.v[late]], [out.w[late]], params, geo)
        best = max(best, (ask["wheel_torque_max_nm"], by))
    load = max(spec.priors[n].sd for n in MASS_GAIN[1:])
    margin = math.log(prior.nominal / best[0]) / math.hypot(prior.sd, load)
    return TorqueReach(ask_nm=best[0], cap_nm=float(prior.nominal), margin_sd=margin, by=best[1])


def unreachable(spec: Any) -> dict[str, str]:
    """What no command within ``spec``'s limits can identify, and why (from the spec alone).

    A wheel torque cap the commands' largest ask (:func:`torque_cap_reach`) stays more than
    :data:`REACH_SD` combined prior sd below: no script within the limits makes a wheel
    saturate there, so velocity data say nothing of the cap.

    Examples
    --------
    >>> from robots.spec import load_spec
    >>> sorted(unreachable(load_spec("turtlebot2")))
    ['wheel_torque_max_nm']
    >>> unreachable(load_spec("turtlebot3_burger"))
    {}
    """
    reach = torque_cap_reach(spec)
    if reach is None or reach.reachable:
        return {}
    return {
        "wheel_torque_max_nm": (
            f"no command within the limits reaches the cap: {reach.by} asks at most "
            f"{reach.ask_nm:.3g} N m per wheel, {reach.margin_sd:.1f} prior sd below the cap "
            f"({reach.cap_nm:.3g} N m)"
        )
    }


def weakly_identified(spec: Any) -> dict[str, str]:
    """What one session of a plan may leave near its prior on ``spec``'s base, and why.

    From the spec alone: the mass-gain direction (velocity data fix each axis's response
    time, not the mass and the gain apart); a wheel torque cap within reach of the commands
    (:func:`torque_cap_reach`; one out of reach is :func:`unreachable`), which a base whose
    wheels do not saturate at the plan's largest ask bounds only from below; and, behind PI
    wheel loops (a prior
    on ``speed_loop_ki_per_s`` centred above 0), viscous friction whose prior sd is below
    :data:`WEAK_FRICTION_SHARE` of the loop's proportional gain: the loops cancel friction at
    any steady speed, so it shows only in the transients' damping (on a base with no velocity
    smoother, where each command change is a step, less than the commands' timing jitter moves
    the transients).

    Examples
    --------
    >>> from robots.spec import load_spec
    >>> weak = weakly_identified(load_spec("turtlebot2"))
    >>> sorted(weak)
    ['added_mass_kg', 'added_yaw_inertia_kgm2', 'viscous_v_ns_per_m']
    >>> "bounds the cap only from below" in weakly_identified(load_spec("turtlebot3_burger"))[
    ...     "wheel_torque_max_nm"]
    True
    """
    drive, geo, priors = spec.drive, spec.geometry, spec.priors
    r, h, k = geo.wheel_radius_m, 0.5 * geo.wheel_separation_m, drive.motor_gain_nms_per_rad
    out = {
        name: f"the mass-gain direction: velocity data fix m/K, not {name} and the gain apart"
        for name in MASS_GAIN[1:]
    }
    reach = torque_cap_reach(spec)
    if reach is not None and reach.reachable:
        out["wheel_torque_max_nm"] = (
            f"{reach.by} asks up to {reach.ask_nm:.3g} N m per wheel, the cap's centre is "
            f"{reach.cap_nm:.3g} N m: a base whose wheels do not saturate there bounds the cap "
            "only from below"
        )
    if priors["speed_loop_ki_per_s"].nominal > 0:
        # a friction prior whose sd is this small a share of the loop's proportional gain hides
        # behind it (docs/transfer.md: the Burger's 2.3-2.4 % stay near their priors on the
        # plant, the Kobuki's 12 % yaw term is informed)
        kv, kw = 2.0 * k / r**2, 2.0 * k * (h / r) ** 2  # N s/m, N m s/rad
        # with no smoother every command change is a step into the loops, and a command's
        # timing jitter moves the transients more than one prior sd of friction does
        smoothed = math.isfinite(drive.accel_lim_v_mps2) and math.isfinite(drive.accel_lim_w_radps2)
        jitter = "" if smoothed else ", less than the commands' timing jitter moves there"
        for name, gain in (("viscous_v_ns_per_m", kv), ("viscous_w_nms_per_rad", kw)):
            sd = priors[name].sd * SCHEMA[name].reference(geo)  # N s/m, N m s/rad
            if 0 < sd < WEAK_FRICTION_SHARE * gain:
                out[name] = (
                    "PI wheel loops cancel friction at a steady speed; in transients one prior "
                    f"sd is {100.0 * sd / gain:.2g} % of the loop's gain" + jitter
                )
    return out


def _kind_scripts(plan: ExcitationPlan) -> dict[str, tuple[FloatArray, FloatArray]]:
    """The plan's commands, and each of its block kinds alone, repeated for the plan's
    length (each block starts and ends at rest and returns to its start: still within the
    floor), from the same 1.5 s rest to the same 1 s stop."""
    hz, n = plan.rate_hz, plan.t_s.size
    lead, tail = round(1.5 * hz), round(1.0 * hz)
    out = {"the plan": (plan.v_mps, plan.w_radps)}
    for kind in dict.fromkeys(b.kind for b in plan.blocks):
        spans = [
            (round(b.start_s * hz), round(b.end_s * hz))
            for b in plan.blocks
            if b.kind == kind and b.end_s <= plan.duration_s - 1.0
        ]
        if not spans:
            continue
        rows = np.concatenate([np.arange(a, b) for a, b in spans])
        reps = math.ceil(max(n - lead - tail, 1) / rows.size)
        idx = np.tile(rows, reps)[: max(n - lead - tail, 0)]
        cmd = np.zeros((n, 2))
        cmd[lead : lead + idx.size, 0] = plan.v_mps[idx]
        cmd[lead : lead + idx.size, 1] = plan.w_radps[idx]
        out[f"{kind} alone"] = (cmd[:, 0].copy(), cmd[:, 1].copy())
    return out


def _script_ratios(
    spec: Any,
    t_s: FloatArray,
    cmd: tuple[FloatArray, FloatArray],
    names: list[str],
    noise: tuple[float, float],
    jitter_s: float,
) -> FloatArray:
    """Posterior over prior sd of ``names`` from one noise-free script on the drive model at
    the priors' centres (no torque cap, no torque-speed line): the Fisher information of the
    30 Hz v and w under white ``noise``, each changing command's arrival a nuisance of sd
    ``jitter_s`` (marginalised: :mod:`sysid._timing`), plus the priors."""
    # scipy-backed: loaded when a bound is computed, not by every importer of sysid.plan
    # (sysid.synthetic, and through it the light `agree` path)
    from sysid._timing import Whitener, arrival_sensitivities, logs_key

    centre, geo = _centre(spec), spec.geometry
    t_meas = np.arange(0.0, t_s[-1] + 1.0 / _BOUND_ODOM_HZ, 1.0 / _BOUND_ODOM_HZ)
    zeros = np.zeros(t_meas.size)
    log = LogArrays(
        cmd_t_s=t_s, cmd_v=cmd[0], cmd_w=cmd[1], meas_t_s=t_meas, meas_v=zeros, meas_w=zeros
    )
    mapper = Mapper(geo, centre, spec.priors)
    prob = Problem(
        [log], mapper, (), {}, scale_v=noise[0], scale_w=noise[1], dt_s=DEFAULT_DT_S,
        v_window_s=spec.odometry.v_window_s, w_source=spec.odometry.w_source,
    )  # fmt: skip
    z0 = np.array([mapper.z(centre, n) for n in names])
    sd = np.array([spec.priors[n].sd for n in names])
    others = {n: float(getattr(centre, n)) for n in SCHEMA}
    moved = []
    for j in range(len(names)):
        for sign in (1.0, -1.0):
            z = z0.copy()
            z[j] += sign * _BOUND_STEP * sd[j]
            moved.append(centre.replace(**coords_to_values(names, z, geo, others)))
    y = prob.scaled_sim_many(moved)
    jac = (y[0::2] - y[1::2]).T / (2.0 * _BOUND_STEP)  # rows: noise units; columns: per prior sd
    if jitter_s > 0:
        sens = arrival_sensitivities(prob, centre)
        whiten = Whitener.of(
            sens, sigma_t_s=jitter_s, scale_v=1.0, scale_w=1.0, key=logs_key(prob.logs)
        )
        jac = whiten.apply(jac.T).T
    cov = np.linalg.inv(jac.T @ jac + np.eye(len(names)))
    return np.sqrt(np.clip(np.diag(cov), 0.0, 1.0))


def information_bound(
    spec: Any,
    duration_s: float,
    *,
    rate_hz: float = 10.0,
    area_m: float = 3.0,
    noise: tuple[float, float] = REFERENCE_NOISE,
    jitter_s: float = REFERENCE_JITTER_S,
) -> InformationBound:
    """The best one session of ``duration_s`` can inform each of ``spec``'s smooth drive
    parameters (the ones with a prior that are not :data:`LIMITS`), as post/prior sd.

    The Fisher information (Cramér-Rao: no unbiased fit does better) of noise-free scripts on
    the drive model at the priors' centres, with no torque cap and no torque-speed line (no
    limit of the mass enters), read as the spec's odometry reads the base (30 Hz, v over the
    encoder window) with white ``noise`` (m/s, rad/s), each changing command's arrival time a
    nuisance of sd ``jitter_s`` (s), combined with the priors. The scripts are the plan of
    that length (``rate_hz``, ``area_m``: :func:`plan_excitation`) and each of its block kinds
    alone for the whole length; the least ratio of each parameter is kept. A longer session,
    less noise or less jitter lowers it. A bound, not a forecast: a fit of a base whose
    physics the drive model lumps differently (per-wheel friction, a discrete loop) reports
    more.

    Examples
    --------
    >>> from robots.spec import load_spec
    >>> bound = information_bound(load_spec("turtlebot3_burger"), 20.0)
    >>> round(bound.sd_ratio["viscous_v_ns_per_m"], 2), bound.by["viscous_v_ns_per_m"]
    (0.79, 'the plan')
    """
    plan = plan_excitation(spec, duration_s, rate_hz=rate_hz, area_m=area_m)
    if not (jitter_s >= 0 and min(noise) > 0):
        raise SysidValueError(
            f"the information bound needs noise > 0 and jitter_s >= 0, got noise {noise!r} "
            f"and jitter_s {jitter_s!r}"
        )
    names = [n for n, p in spec.priors.items() if n in SCHEMA and p.informative and n not in LIMITS]
    best = dict.fromkeys(names, math.inf)
    by = dict.fromkeys(names, "")
    for label, cmd in _kind_scripts(plan).items():
        ratios = _script_ratios(spec, plan.t_s, cmd, names, noise, jitter_s)
        for name, r in zip(names, ratios.tolist(), strict=True):
            if r < best[name]:
                best[name], by[name] = r, label
    return InformationBound(
        duration_s=float(duration_s),
        noise=(float(noise[0]), float(noise[1])),
        jitter_s=float(jitter_s),
        sd_ratio=best,
        by=by,
    )


def beyond_session(bound: InformationBound) -> dict[str, str]:
    """What no session of the bound's length identifies, and why: the smooth parameters whose
    best case (:func:`information_bound`) stays above :data:`BEYOND_SD_RATIO` of the prior sd.

    Examples
    --------
    >>> from robots.spec import load_spec
    >>> sorted(beyond_session(information_bound(load_spec("turtlebot3_burger"), 20.0)))[-2:]
    ['viscous_v_ns_per_m', 'viscous_w_nms_per_rad']
    """
    return {
        name: (
            f"informed to {r:.2f} of its prior sd at best, by {bound.by[name]} (Fisher "
            f"information of {bound.duration_s:g} s of the plan or of one of its block kinds "
            f"alone, at the priors' centres, noise {1e3 * bound.noise[0]:.3g} mm/s and "
            f"{bound.noise[1]:.3g} rad/s, {1e3 * bound.jitter_s:.3g} ms command jitter)"
        )
        for name, r in bound.sd_ratio.items()
        if r > BEYOND_SD_RATIO
    }


def _extent(v: FloatArray, w: FloatArray, dt: float) -> float:
    """Largest distance from the start of the perfectly tracked (unicycle) path, m."""
    yaw = np.concatenate(([0.0], np.cumsum(w * dt)))[:-1] + 0.5 * w * dt
    x = np.cumsum(v * np.cos(yaw) * dt)
    y = np.cumsum(v * np.sin(yaw) * dt)
    return float(np.hypot(x, y).max()) if x.size else 0.0


def plan_excitation(
    spec: Any, duration_s: float, *, rate_hz: float = 10.0, area_m: float = 3.0
) -> ExcitationPlan:
    """The excitation plan of ``spec``'s base for ``duration_s`` seconds.

    Parameters
    ----------
    spec : robots.spec.RobotSpec
        The base: its speed limits, wheel-speed cap and track.
    duration_s : float
        Length of the script, s (>= 10).
    rate_hz : float
        Publishing rate of the commands, Hz.
    area_m : float
        Side of the free floor square the base starts in the middle of, m: held legs are
        shortened so that the ideal path stays within half of it from the start.

    Returns
    -------
    ExcitationPlan
        The commands and what each block is designed to identify.
    """
    _check(spec, duration_s, rate_hz, area_m)
    drive, geo = spec.drive, spec.geometry
    v = min(drive.speed_lim_v_mps, spec.max_v_mps)
    w = min(drive.speed_lim_w_radps, spec.max_w_radps)
    wheel = drive.wheel_speed_max_radps
    if not math.isfinite(wheel):
        wheel = OVERDRIVE * v / geo.wheel_radius_m
    lim = {
        "v_mps": float(v),
        "w_radps": float(w),
        "wheel_radps": float(wheel),
        "wheel_mps": float(wheel * geo.wheel_radius_m),
        "half_track_m": 0.5 * geo.wheel_separation_m,
        "area_m": float(area_m),
        # in-place turns held until the smoother has reached 110 % of the limit, and 0.8 s on
        "hold_w_s": float(np.clip(OVERDRIVE * w / drive.accel_lim_w_radps2 + 0.8, 1.2, 4.0)),
    }
    # the longest held leg runs at 110 % of the limit for hold_s: half the square's half-side
    hold_s = float(np.clip(0.25 * area_m / (OVERDRIVE * v), 0.6, 2.0))
    script = _Script(float(rate_hz))
    script.rows += script.hold(0.0, 0.0, 1.5)
    n = round(duration_s * rate_hz)
    blocks: list[PlanBlock] = []
    k = 0
    while len(script.rows) < n:
        # the speed levels only in a cycle the script holds whole: a shorter script keeps the
        # blocks that reach the limits
        trial = _Script(script.hz)
        trial.rows = list(script.rows)
        _cycle(trial, k, lim, hold_s, levels=True)
        blocks += _cycle(script, k, lim, hold_s, levels=len(trial.rows) <= n)
        k += 1
    cmd = np.asarray(script.rows[:n], dtype=np.float64)
    cmd[-round(1.0 * rate_hz) :] = 0.0  # the script ends at rest
    ends = [min(b.end_s, duration_s) for b in blocks]
    known = {n for n, p in spec.priors.items() if p.sd == 0}
    kept = tuple(
        PlanBlock(
            kind=b.kind,
            start_s=b.start_s,
            end_s=e,
            identifies=tuple(n for n in b.identifies if n not in known),
        )
        for b, e in zip(blocks, ends, strict=True)
        if b.start_s < duration_s - 1.0
    )
    return ExcitationPlan(
        robot=spec.name,
        t_s=np.arange(n) / float(rate_hz),
        v_mps=cmd[:, 0].copy(),
        w_radps=cmd[:, 1].copy(),
        rate_hz=float(rate_hz),
        duration_s=float(duration_s),
        blocks=kept,
        limits={k: lim[k] for k in ("v_mps", "w_radps", "wheel_radps")},
        extent_m=_extent(cmd[:, 0], cmd[:, 1], 1.0 / rate_hz),
        weak=weakly_identified(spec),
        unreachable=unreachable(spec),
    )
