"""Sanity checks of a robot spec: geometry, and a 1 s drive test in pybullet.

``sim2real robots check SPEC`` runs them, and every :class:`~robots.pybullet_robot.PybulletRobot`
runs them (once per spec and process) before it builds a robot, so a spec that would simulate
nonsense is refused with the reason instead of producing plausible-looking numbers. (A spec
whose body reached into the ground once drove *backwards* on a forward command in pybullet.)

Checks
------
body clear of the ground
    The lowest point of the body shape is at least :data:`MIN_CLEARANCE_M` above flat ground.
wheel radius vs axle height
    The wheels' lowest points are on the ground plane (``link_height_m`` and the casters put
    them there; checked to 1 mm).
centre of mass inside the support polygon
    The mass-weighted centre of the base, point masses, casters and wheels lies inside the
    convex hull of the wheel and caster ground contacts, at least :data:`MIN_COM_MARGIN_M`
    from its edges (a base with casters on one side only would tip).
wheels touch the ground
    In pybullet, after 0.25 s at rest both wheel links have ground contact.
forward drive
    A forward command of half the top speed for 1 s (drive chain without delay, timeout or
    smoother, so only the body and wheels are tested) moves the base forward at a mean speed
    over the last 0.5 s within :data:`SPEED_TOLERANCE` (20 %) of the commanded (kinematic)
    speed, and it stays on its heading.
turn
    A yaw-rate command of half the top rate for 1 s turns the base with the commanded sign.

Examples
--------
>>> from robots.spec import load_spec
>>> report = check_spec(load_spec("turtlebot3_burger"))
>>> report.passed
True
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

from robots._urdf import urdf_text
from robots.errors import SpecError
from robots.params import DriveParams
from robots.spec import RobotSpec

if TYPE_CHECKING:
    from robots._pybullet_robot import UncheckedPybulletRobot

__all__ = [
    "MIN_CLEARANCE_M",
    "MIN_COM_MARGIN_M",
    "SPEED_TOLERANCE",
    "CheckItem",
    "SpecCheck",
    "check_spec",
    "ensure_spec_ok",
]


@dataclass(frozen=True, kw_only=True)
class CheckItem:
    """One check: its name, whether it passed, and the numbers behind it (one sentence)."""

    name: str
    passed: bool
    detail: str


@dataclass(frozen=True, kw_only=True)
class SpecCheck:
    """All checks of one spec.

    Attributes
    ----------
    robot : str
        The spec's name.
    source : str
        The spec file.
    items : tuple of CheckItem
        Every check run, in order.
    """

    robot: str
    source: str
    items: tuple[CheckItem, ...]

    @property
    def passed(self) -> bool:
        """True when every check passed."""
        return all(i.passed for i in self.items)

    def reason(self) -> str:
        """One sentence naming the spec and its first failed check ("" when all passed)."""
        failed = [i for i in self.items if not i.passed]
        if not failed:
            return ""
        more = f" (and {len(failed) - 1} more failed check(s))" if len(failed) > 1 else ""
        return (
            f"robot spec '{self.source}' fails the check '{failed[0].name}': "
            f"{failed[0].detail}{more}; fix the spec (see `sim2real robots check`)"
        )


# ------------------------------------------------------------------------------- geometry

#: Smallest allowed gap between the body and flat ground, m.
MIN_CLEARANCE_M = 0.001
#: Smallest allowed distance of the centre of mass from the support polygon's edges, m.
MIN_COM_MARGIN_M = 0.005


def _body_clearance(spec: RobotSpec) -> CheckItem:
    bottom = spec.base_link_height_m + spec.body.xyz_m[2] - 0.5 * spec.body.size_m[2]
    ok = bottom >= MIN_CLEARANCE_M
    where = "above" if bottom >= 0 else "below"
    return CheckItem(
        name="body clear of the ground",
        passed=ok,
        detail=f"the body's lowest point is {abs(bottom):.4f} m {where} the ground "
        f"(base.link_height_m + base.body.xyz_m[2] - height/2; needs >= {MIN_CLEARANCE_M} m)",
    )


def _wheel_ground(spec: RobotSpec) -> CheckItem:
    lowest = spec.base_link_height_m + spec.wheel_positions_m[0][2] - spec.wheels.radius_m
    return CheckItem(
        name="wheels reach the ground",
        passed=abs(lowest) <= 1e-3,
        detail=f"the wheels' lowest points are at z = {lowest:+.4f} m (needs 0 +- 0.001 m)",
    )


def _hull(points: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """Convex hull, counter-clockwise (Andrew's monotone chain)."""
    pts = sorted(set(points))
    if len(pts) < 3:
        return pts

    def cross(o: tuple[float, float], a: tuple[float, float], b: tuple[float, float]) -> float:
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list[tuple[float, float]] = []
    upper: list[tuple[float, float]] = []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    for p in reversed(pts):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    return lower[:-1] + upper[:-1]


def _margin(hull: list[tuple[float, float]], x: float, y: float) -> float:
    """Signed distance of (x, y) inside a counter-clockwise convex polygon (< 0 outside)."""
    if len(hull) < 3:
        return -math.inf
    out = math.inf
    for (ax, ay), (bx, by) in zip(hull, hull[1:] + hull[:1], strict=True):
        ex, ey = bx - ax, by - ay
        out = min(out, (ex * (y - ay) - ey * (x - ax)) / math.hypot(ex, ey))
    return out


def centre_of_mass_xy(spec: RobotSpec) -> tuple[float, float]:
    """Mass-weighted (x, y) of base (at the axle midpoint), point masses, casters, wheels, m."""
    items = [(spec.base_mass_kg, 0.0, 0.0)]
    items += [(p.mass_kg, p.xyz_m[0], p.xyz_m[1]) for p in spec.point_masses]
    items += [(c.mass_kg, c.xyz_m[0], c.xyz_m[1]) for c in spec.casters]
    items += [(spec.wheels.mass_kg, w[0], w[1]) for w in spec.wheel_positions_m]
    total = sum(m for m, _, _ in items)
    return sum(m * x for m, x, _ in items) / total, sum(m * y for m, _, y in items) / total


def _com_support(spec: RobotSpec) -> CheckItem:
    contacts = [(w[0], w[1]) for w in spec.wheel_positions_m]
    contacts += [(c.xyz_m[0], c.xyz_m[1]) for c in spec.casters]
    x, y = centre_of_mass_xy(spec)
    margin = _margin(_hull(contacts), x, y)
    if math.isinf(margin):
        detail = (
            "the support polygon is only the wheel axle (no caster off the axle), so the base "
            "would tip; add casters in front of and behind the axle"
        )
    else:
        where = "inside" if margin >= 0 else "outside"
        detail = (
            f"the centre of mass ({x:+.4f}, {y:+.4f}) m is {abs(margin):.4f} m {where} the "
            f"support polygon of the wheel and caster contacts (needs >= {MIN_COM_MARGIN_M} m "
            "inside; casters on both sides of the axle)"
        )
    return CheckItem(
        name="centre of mass inside the support polygon",
        passed=margin >= MIN_COM_MARGIN_M,
        detail=detail,
    )


# ------------------------------------------------------------------------------- drive test

#: Allowed relative deviation of the driven speed from the commanded one.
SPEED_TOLERANCE = 0.2
#: Rest before the contact check, s.
_SETTLE_S = 0.25
#: Length of the forward and turn tests, s.
_DRIVE_S = 1.0


def _drive_items(spec: RobotSpec) -> list[CheckItem]:
    # pybullet only for the drive test: `robots check --no-drive` stays light
    from robots._pybullet_robot import UncheckedPybulletRobot

    params = spec.drive.replace(
        delay_s=0.0, cmd_timeout_s=math.inf, accel_lim_v_mps2=math.inf, accel_lim_w_radps2=math.inf
    )
    v_cmd, w_cmd = _test_commands(spec, params)
    with UncheckedPybulletRobot(spec, params=params) as robot:
        items = [_contact_item(robot)]
        robot.reset()
        items.append(_forward_item(robot, v_cmd))
        robot.reset()
        items.append(_turn_item(robot, w_cmd))
    return items


def _test_commands(spec: RobotSpec, params: DriveParams) -> tuple[float, float]:
    """Half the top speed and half the top yaw rate the spec and its drive allow."""
    geo = spec.geometry
    v_top = min(
        spec.max_v_mps, params.speed_lim_v_mps, params.wheel_speed_max_radps * geo.wheel_radius_m
    )
    w_top = min(
        spec.max_w_radps,
        params.speed_lim_w_radps,
        2.0 * params.wheel_speed_max_radps * geo.wheel_radius_m / geo.wheel_separation_m,
    )
    return 0.5 * v_top, 0.5 * w_top


def _contact_item(robot: UncheckedPybulletRobot) -> CheckItem:
    robot.step(0.0, 0.0, _SETTLE_S)
    touching = robot.wheel_contacts()
    return CheckItem(
        name="wheels touch the ground",
        passed=all(touching),
        detail=f"after {_SETTLE_S} s at rest in pybullet the left/right wheel ground "
        f"contacts are {touching[0]}/{touching[1]} (both must touch)",
    )


def _forward_item(robot: UncheckedPybulletRobot, v_cmd: float) -> CheckItem:
    robot.step(v_cmd, 0.0, 0.5 * _DRIVE_S)
    x0, _, _ = robot.pose
    robot.step(v_cmd, 0.0, 0.5 * _DRIVE_S)
    x1, _, yaw1 = robot.pose
    speed = (x1 - x0) / (0.5 * _DRIVE_S)  # along the start heading (+x)
    rel = speed / v_cmd - 1.0
    return CheckItem(
        name="forward drive",
        passed=abs(rel) <= SPEED_TOLERANCE and abs(yaw1) < 0.2,
        detail=f"a forward command of {v_cmd:.3f} m/s drove the base at {speed:+.3f} "
        f"m/s ({rel:+.0%} of the kinematic speed; needs within +-{SPEED_TOLERANCE:.0%}) "
        f"and turned it by {yaw1:+.3f} rad (needs |yaw| < 0.2)",
    )


def _turn_item(robot: UncheckedPybulletRobot, w_cmd: float) -> CheckItem:
    robot.step(0.0, w_cmd, 0.05)
    yaw, last = robot.pose[2], robot.pose[2]
    for _ in range(round(_DRIVE_S / 0.05) - 1):  # unwrapped heading (turns > pi)
        robot.advance(0.05)
        now = robot.pose[2]
        yaw += math.remainder(now - last, 2.0 * math.pi)
        last = now
    return CheckItem(
        name="turn",
        passed=yaw * w_cmd > 0 and abs(yaw) > 0.2 * w_cmd * _DRIVE_S,
        detail=f"a yaw-rate command of {w_cmd:+.3f} rad/s turned the base by {yaw:+.3f} "
        f"rad in {_DRIVE_S} s (needs the same sign and at least 20 % of "
        f"{w_cmd * _DRIVE_S:+.3f} rad)",
    )


def check_spec(spec: RobotSpec, *, drive_test: bool = True) -> SpecCheck:
    """Run the geometry checks and (unless ``drive_test=False``) the pybullet drive test.

    The drive test only runs when the geometry checks pass (a body in the ground makes the
    physics meaningless).
    """
    items = [_body_clearance(spec), _wheel_ground(spec), _com_support(spec)]
    if drive_test and all(i.passed for i in items):
        items += _drive_items(spec)
    return SpecCheck(robot=spec.name, source=str(spec.path or spec.name), items=tuple(items))


_CHECKED: dict[str, SpecCheck] = {}


def _key(spec: RobotSpec) -> str:
    return hashlib.sha256((urdf_text(spec) + repr(spec.drive)).encode()).hexdigest()


def ensure_spec_ok(spec: RobotSpec) -> None:
    """Refuse a spec that fails :func:`check_spec` (cached per spec content and process).

    Raises
    ------
    SpecError
        With :meth:`SpecCheck.reason`: the spec file, the failed check and its numbers.
    """
    key = _key(spec)
    if key not in _CHECKED:
        _CHECKED[key] = check_spec(spec)
    report = _CHECKED[key]
    if not report.passed:
        raise SpecError(report.reason())
