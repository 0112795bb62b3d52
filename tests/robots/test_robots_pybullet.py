"""The pybullet robots: caps, Coulomb stop, breakaway, delay, parameters read back, and agreement
with the reduced model (same DriveParams, same commands)."""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np
import pybullet as p
import pytest

from robots import DriveParams, PybulletRobot, RobotSpec, load_spec, simulate
from robots.errors import RobotsValueError
from robots.pybullet_robot import DriveParamsNotAppliedError
from robots.spec import lumped_base_mass_kg
from robots.world import add_ground

ROBOTS = ["turtlebot2", "turtlebot3_burger", "turtlebot3_waffle_pi"]


@pytest.fixture(params=ROBOTS)
def robot(request: pytest.FixtureRequest) -> Iterator[PybulletRobot]:
    bot = PybulletRobot(load_spec(request.param))
    yield bot
    bot.close()


def _steady(spec: RobotSpec, v_ref: float, w_ref: float) -> tuple[float, float]:
    """Analytic steady state of the P loops with Coulomb and viscous friction, or where the
    motors' torque-speed line meets that load if it binds first."""
    d, g = spec.drive, spec.geometry
    r, sep, k = g.wheel_radius_m, g.wheel_separation_m, d.motor_gain_nms_per_rad
    kv, kw = 2 * k / r**2, k * sep**2 / (2 * r**2)
    v = (kv * v_ref - math.copysign(d.coulomb_v_fwd_n, v_ref)) / (kv + d.viscous_v_ns_per_m)
    w = (kw * w_ref - math.copysign(d.coulomb_w_nm, w_ref)) / (kw + d.viscous_w_nms_per_rad)
    ts, w0, half = d.wheel_stall_torque_nm, d.wheel_no_load_speed_radps, 0.5 * sep
    if math.isfinite(w0):
        # per wheel, speed magnitudes: ts (1 - |v| / (r w0)) = r (F_c + b |v|) / 2
        v_line = (ts - 0.5 * r * d.coulomb_v_fwd_n) / (
            ts / (r * w0) + 0.5 * r * d.viscous_v_ns_per_m
        )
        # ts (1 - |w| half / (r w0)) = r (T_c + b |w|) / (2 half)
        w_line = (ts - r * d.coulomb_w_nm / sep) / (
            ts * half / (r * w0) + r * d.viscous_w_nms_per_rad / sep
        )
        v = math.copysign(min(abs(v), v_line), v)
        w = math.copysign(min(abs(w), w_line), w)
    return (v if v_ref else 0.0), (w if w_ref else 0.0)


def _hold(robot: PybulletRobot, v: float, w: float, seconds: float, dt: float = 0.1) -> None:
    for _ in range(round(seconds / dt)):
        robot.step(v, w, dt)


def test_loads_in_direct_mode_at_rest_on_its_wheels(robot: PybulletRobot) -> None:
    assert p.getConnectionInfo(robot.client)["connectionMethod"] == p.DIRECT
    _hold(robot, 0.0, 0.0, 0.5)
    x, y, yaw = robot.pose
    assert abs(x) < 1e-4 and abs(y) < 1e-4 and abs(yaw) < 1e-4
    v, w = robot.velocity
    assert abs(v) < 1e-4 and abs(w) < 1e-4
    pos, _ = p.getBasePositionAndOrientation(robot.body_id, physicsClientId=robot.client)
    assert pos[2] == pytest.approx(robot.spec.base_link_height_m, abs=1e-3)
    wheel_contacts = [
        c
        for c in p.getContactPoints(bodyA=robot.body_id, physicsClientId=robot.client)
        if c[3] >= 0
    ]
    load = sum(c[9] for c in wheel_contacts)
    # the wheels carry most of the weight (the casters, touching the ground, take the rest)
    assert load > 0.6 * robot.spec.rigid_mass_kg * 9.81


@pytest.mark.slow
def test_drives_straight_at_the_spec_speed_cap(robot: PybulletRobot) -> None:
    spec = robot.spec
    _hold(robot, spec.max_v_mps, 0.0, 3.0)
    v, w = robot.velocity
    v_ss, _ = _steady(spec, spec.max_v_mps, 0.0)
    assert v == pytest.approx(v_ss, rel=5e-3)  # golden: P loop, friction, the motors' line
    assert v == pytest.approx(spec.max_v_mps, rel=0.05)  # Coulomb droop < 5 % by design
    assert abs(w) < 0.01
    _, y, yaw = robot.pose
    assert abs(y) < 0.01 and abs(yaw) < 0.01
    odom_v, odom_w = robot.odometry()
    assert odom_v == pytest.approx(v, rel=0.01) and abs(odom_w - w) < 1e-9


@pytest.mark.slow
def test_turns_in_place_at_the_spec_yaw_rate_cap(robot: PybulletRobot) -> None:
    spec = robot.spec
    _hold(robot, 0.0, spec.max_w_radps, 3.0)
    v, w = robot.velocity
    _, w_ss = _steady(spec, 0.0, spec.max_w_radps)
    assert w == pytest.approx(w_ss, rel=5e-3)
    assert w == pytest.approx(spec.max_w_radps, rel=0.05)
    assert abs(v) < 0.005
    x, y, _ = robot.pose
    assert math.hypot(x, y) < 0.01


def test_reverse_command_above_the_cap_is_clamped(robot: PybulletRobot) -> None:
    spec = robot.spec
    _hold(robot, -3.0 * spec.max_v_mps, 0.0, 3.0)
    v_ss, _ = _steady(spec, -spec.max_v_mps, 0.0)
    assert robot.velocity[0] == pytest.approx(v_ss, rel=5e-3)


def test_stops_under_coulomb_friction_and_stays_stopped(robot: PybulletRobot) -> None:
    spec = robot.spec
    _hold(robot, 0.5 * spec.max_v_mps, 0.5 * spec.max_w_radps, 2.0)
    assert robot.velocity[0] > 0.2 * spec.max_v_mps
    _hold(robot, 0.0, 0.0, spec.drive.delay_s + 1.5)
    v, w = robot.velocity
    assert abs(v) < 1e-3 and abs(w) < 1e-3
    before = robot.pose
    _hold(robot, 0.0, 0.0, 1.0)
    after = robot.pose
    assert math.hypot(after[0] - before[0], after[1] - before[1]) < 1e-3
    assert abs(after[2] - before[2]) < 1e-3


def test_command_below_breakaway_does_not_move_the_base(robot: PybulletRobot) -> None:
    spec, d, g = robot.spec, robot.spec.drive, robot.spec.geometry
    k, r, sep = d.motor_gain_nms_per_rad, g.wheel_radius_m, g.wheel_separation_m
    v_break = d.coulomb_v_fwd_n * r**2 / (2 * k)  # drive force 2K v/r^2 = Coulomb level
    w_break = d.coulomb_w_nm * 2 * r**2 / (k * sep**2)
    _hold(robot, 0.5 * v_break, 0.0, 2.0)
    x, y, yaw = robot.pose
    assert math.hypot(x, y) < 1e-3
    _hold(robot, 0.0, 0.5 * w_break, 2.0)
    assert abs(robot.pose[2] - yaw) < 2e-3
    # and 3x the breakaway command does move it
    _hold(robot, 3.0 * v_break, 0.0, 2.0)
    assert robot.pose[0] - x > 0.5 * 2.0 * v_break
    assert spec.drive.coulomb_v_fwd_n > 0


def test_command_timeout_stops_the_base(robot: PybulletRobot) -> None:
    spec = robot.spec
    robot.step(0.5 * spec.max_v_mps, 0.0, 0.1)
    robot.advance(spec.drive.delay_s + spec.drive.cmd_timeout_s - 0.15)
    assert robot.velocity[0] > 0.2 * spec.max_v_mps  # still driving before the timeout
    robot.advance(1.5)
    assert abs(robot.velocity[0]) < 1e-3


def test_transport_delay_holds_the_response_back(robot: PybulletRobot) -> None:
    spec = robot.spec
    t = np.arange(0.0, spec.drive.delay_s + 0.3, 1.0 / 240.0)
    out = robot.replay(
        cmd_t_s=np.array([0.0]),
        cmd_v=np.array([spec.max_v_mps]),
        cmd_w=np.array([0.0]),
        t_out_s=t,
    )
    before = t < spec.drive.delay_s - 1e-9
    assert np.max(np.abs(out.v[before])) < 1e-4
    assert out.v[-1] > 0.1 * spec.max_v_mps
    ref = simulate(
        spec.drive,
        spec.geometry,
        cmd_t_s=np.array([0.0]),
        cmd_v=np.array([spec.max_v_mps]),
        cmd_w=np.array([0.0]),
        t_out_s=t,
    )
    assert np.max(np.abs(out.v - ref.v)) < 2e-3


def test_drive_params_are_applied_and_read_back(robot: PybulletRobot) -> None:
    spec = robot.spec
    params = spec.drive.replace(added_mass_kg=0.75, added_yaw_inertia_kgm2=0.004, delay_s=0.11)
    robot.set_drive_params(params)
    assert robot.get_drive_params() == params
    info = p.getDynamicsInfo(robot.body_id, -1, physicsClientId=robot.client)
    assert info[0] == pytest.approx(lumped_base_mass_kg(spec) + 0.75, rel=1e-9)
    assert info[1] == 0.0  # frictionless casters
    base_izz = info[2][2]
    robot.set_drive_params(spec.drive)
    info2 = p.getDynamicsInfo(robot.body_id, -1, physicsClientId=robot.client)
    assert base_izz - info2[2][2] == pytest.approx(0.004, rel=1e-6)
    with pytest.raises(RobotsValueError, match="added_mass_kg"):
        robot.set_drive_params(spec.drive.replace(added_mass_kg=-lumped_base_mass_kg(spec)))
    assert robot.get_drive_params() == spec.drive


def test_a_parameter_pybullet_ignores_is_detected(monkeypatch: pytest.MonkeyPatch) -> None:
    robot = PybulletRobot("turtlebot3_burger")
    real = p.changeDynamics

    def drop_mass(*args: object, **kwargs: object) -> None:
        kwargs.pop("mass", None)
        real(*args, **kwargs)

    monkeypatch.setattr("robots._pybullet_robot.p.changeDynamics", drop_mass)
    with pytest.raises(DriveParamsNotAppliedError, match="base mass"):
        robot.set_drive_params(robot.spec.drive.replace(added_mass_kg=0.3))
    monkeypatch.undo()
    robot.close()


def test_added_mass_slows_the_response_as_the_reduced_model_predicts() -> None:
    spec = load_spec("turtlebot3_burger")
    heavy = spec.drive.replace(added_mass_kg=1.0)
    t = np.arange(0.0, 0.6, 0.01)
    cmd = {"cmd_t_s": np.array([0.0]), "cmd_v": np.array([0.2]), "cmd_w": np.array([0.0])}
    with PybulletRobot(spec, params=heavy) as bot:
        out = bot.replay(t_out_s=t, **cmd)
    light = simulate(spec.drive, spec.geometry, t_out_s=t, **cmd)
    model = simulate(heavy, spec.geometry, t_out_s=t, **cmd)
    i = int(np.searchsorted(t, spec.drive.delay_s + 0.05))
    assert out.v[i] < light.v[i] - 0.03
    assert out.v[i] == pytest.approx(model.v[i], abs=2e-3)


def _sequence(spec: RobotSpec) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """~10 s at 10 Hz: steps, an in-place turn, arcs (wheel-cap bound), reversals, stop."""
    vm, wm = spec.max_v_mps, spec.max_w_radps
    segs = [
        (0.0, 0.0, 3),
        (vm, 0.0, 15),
        (0.0, 0.0, 8),
        (0.0, wm, 12),
        (0.6 * vm, 0.6 * wm, 12),
        (vm, -wm, 10),
        (-vm, -0.5 * wm, 12),
        (0.3 * vm, 0.8 * wm, 8),
        (-0.5 * vm, 0.0, 10),
        (0.0, 0.0, 10),
    ]
    v = np.concatenate([np.full(n, a) for a, _, n in segs])
    w = np.concatenate([np.full(n, b) for _, b, n in segs])
    return 0.1 * np.arange(v.size), v, w


@pytest.mark.slow
@pytest.mark.parametrize("name", ROBOTS)
def test_pybullet_agrees_with_the_reduced_model(name: str) -> None:
    """Stated tolerance: RMS < 0.002 m/s and < 0.01 rad/s (reached: ~2e-4 m/s, ~3e-3 rad/s)."""
    spec = load_spec(name)
    t, v, w = _sequence(spec)
    with PybulletRobot(spec) as bot:
        got = np.array([bot.step(a, b, 0.1) for a, b in zip(v, w, strict=True)])
    ref = simulate(spec.drive, spec.geometry, cmd_t_s=t, cmd_v=v, cmd_w=w, t_out_s=t + 0.1)
    rms_v = float(np.sqrt(np.mean((got[:, 0] - ref.v) ** 2)))
    rms_w = float(np.sqrt(np.mean((got[:, 1] - ref.w) ** 2)))
    assert rms_v < 0.002, rms_v
    assert rms_w < 0.01, rms_w
    assert np.max(np.abs(ref.v)) > 0.9 * spec.max_v_mps  # the sequence does reach the caps


@pytest.mark.slow
@pytest.mark.parametrize("name", ROBOTS)
def test_replay_agrees_with_simulate_for_other_params(name: str) -> None:
    """Irregular command times, payload, longer delay and PI wheel loops (the spec's prior
    integral gain): RMS < 0.003 m/s and < 0.015 rad/s."""
    spec = load_spec(name)
    rng = np.random.default_rng(7)
    params = spec.drive.replace(
        added_mass_kg=0.4 * spec.geometry.mass_kg,
        added_yaw_inertia_kgm2=0.3 * spec.geometry.yaw_inertia_kgm2,
        delay_s=0.13,
        speed_loop_ki_per_s=spec.priors["speed_loop_ki_per_s"].nominal,
    )
    cmd_t = np.cumsum(rng.uniform(0.05, 0.15, 80))
    cmd_v = np.repeat(rng.uniform(-1.0, 1.0, 8), 10) * spec.max_v_mps
    cmd_w = np.repeat(rng.uniform(-1.0, 1.0, 8), 10) * spec.max_w_radps
    t_out = np.arange(0.0, cmd_t[-1], 1.0 / 30.0)
    with PybulletRobot(spec, params=params) as bot:
        got = bot.replay(cmd_t_s=cmd_t, cmd_v=cmd_v, cmd_w=cmd_w, t_out_s=t_out)
    ref = simulate(params, spec.geometry, cmd_t_s=cmd_t, cmd_v=cmd_v, cmd_w=cmd_w, t_out_s=t_out)
    assert float(np.sqrt(np.mean((got.v - ref.v) ** 2))) < 0.003
    assert float(np.sqrt(np.mean((got.w - ref.w) ** 2))) < 0.015
    assert float(np.sqrt(np.mean((got.odom_v - got.v) ** 2))) < 0.005
    # the pose integrates the velocity
    heading = np.interp(t_out, got.t_s, got.yaw_rad)
    dx = np.diff(got.x_m)
    expect = 0.5 * (got.v[1:] + got.v[:-1]) * np.cos(heading[:-1]) * np.diff(t_out)
    assert float(np.max(np.abs(dx - expect))) < 2e-3


def test_reset_and_start_pose() -> None:
    with PybulletRobot("turtlebot3_waffle_pi", start_pose=(1.0, -2.0, 0.5)) as bot:
        assert bot.pose == pytest.approx((1.0, -2.0, 0.5), abs=1e-9)
        bot.step(0.2, 0.0, 1.0)
        x, y, _ = bot.pose
        assert x > 1.0 and y > -2.0  # it drove along its 0.5 rad heading
        bot.reset(0.0, 0.0, -1.0)
        assert bot.pose == pytest.approx((0.0, 0.0, -1.0), abs=1e-9)
        assert bot.velocity == pytest.approx((0.0, 0.0), abs=1e-12)
        assert bot.time_s == 0.0


def test_two_robots_share_a_client() -> None:
    client = p.connect(p.DIRECT)
    try:
        p.setGravity(0, 0, -9.81, physicsClientId=client)
        add_ground(client)
        a = PybulletRobot("turtlebot3_burger", client=client, start_pose=(0.0, 0.0, 0.0))
        b = PybulletRobot("turtlebot2", client=client, start_pose=(0.0, 2.0, 0.0))
        a.step(0.2, 0.0, 1.0)
        assert a.pose[0] > 0.05 and abs(b.pose[0]) < 1e-3
        a.close()  # not its client: stays connected
        assert p.isConnected(client)
    finally:
        p.disconnect(client)


def test_bad_arguments_are_refused() -> None:
    client = p.connect(p.DIRECT)
    try:
        with pytest.raises(RobotsValueError, match="setGravity"):
            PybulletRobot("turtlebot2", client=client)
    finally:
        p.disconnect(client)
    with pytest.raises(RobotsValueError, match="physics_hz"):
        PybulletRobot("turtlebot3_burger", physics_hz=0.0)
    with PybulletRobot("turtlebot3_burger") as bot:
        with pytest.raises(RobotsValueError, match="command must be finite"):
            bot.step(float("nan"), 0.0, 0.1)
        with pytest.raises(RobotsValueError, match="duration_s"):
            bot.step(0.1, 0.0, -1.0)
        with pytest.raises(RobotsValueError, match="params"):
            bot.set_drive_params({"delay_s": 0.1})  # type: ignore[arg-type]
        with pytest.raises(RobotsValueError, match="reset pose"):
            bot.reset(float("inf"), 0.0, 0.0)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["turtlebot3_burger", "turtlebot3_waffle_pi"])
def test_reduced_model_fitted_to_a_pybullet_log_recovers_the_parameters(name: str) -> None:
    """What sysid does with synthetic ground truth: the fit lands within 3 % of the truth.

    The robot runs at the reduced model's own step (``1 / DEFAULT_DT_S``, pybullet's default
    240 Hz), so the two discretisations match (a mismatched step biases the fitted yaw inertia
    of the TurtleBot3s, whose yaw loop has a ~20 ms time constant).
    """
    from scipy.optimize import least_squares

    from robots.reduced import DEFAULT_DT_S

    spec = load_spec(name)
    g, d = spec.geometry, spec.drive
    names = [
        "delay_s", "motor_gain_nms_per_rad", "added_mass_kg", "coulomb_v_fwd_n",
        "coulomb_w_nm", "viscous_v_ns_per_m", "added_yaw_inertia_kgm2",
    ]  # fmt: skip
    scale = np.array([
        0.05, d.motor_gain_nms_per_rad, 0.1 * g.mass_kg, d.coulomb_v_fwd_n, d.coulomb_w_nm,
        d.viscous_v_ns_per_m, 0.1 * g.yaw_inertia_kgm2,
    ])  # fmt: skip
    truth = np.array([0.065, 0.8 * d.motor_gain_nms_per_rad, 0.3 * g.mass_kg,
                      1.5 * d.coulomb_v_fwd_n, 1.5 * d.coulomb_w_nm,
                      2.0 * d.viscous_v_ns_per_m, 0.2 * g.yaw_inertia_kgm2])  # fmt: skip

    def params(x: np.ndarray) -> DriveParams:
        values = {k: float(v) for k, v in zip(names, x, strict=True)}
        return d.replace(coulomb_v_bwd_n=values["coulomb_v_fwd_n"], **values)

    rng = np.random.default_rng(11)
    cmd_t = 0.1 * np.arange(400)
    hold = np.repeat(rng.uniform(-1.0, 1.0, (40, 2)), 10, axis=0)
    cmd_v, cmd_w = hold[:, 0] * spec.max_v_mps, hold[:, 1] * spec.max_w_radps
    t_out = np.arange(0.0, 40.0, 1.0 / 30.0)
    kw = {"cmd_t_s": cmd_t, "cmd_v": cmd_v, "cmd_w": cmd_w, "t_out_s": t_out}
    with PybulletRobot(spec, params=params(truth), physics_hz=1.0 / DEFAULT_DT_S) as bot:
        log = bot.replay(**kw)

    def residual(z: np.ndarray) -> np.ndarray:
        r = simulate(params(z * scale), g, **kw)
        return np.concatenate(
            [(r.v - log.odom_v) / spec.max_v_mps, (r.w - log.odom_w) / spec.max_w_radps]
        )

    x0 = np.array([getattr(d, k) for k in names])
    x0[[2, 6]] = 0.0
    lower = np.array([0.0, 1e-4, -0.5 * g.mass_kg, 0.0, 0.0, 0.0, -0.5 * g.yaw_inertia_kgm2])
    fit = least_squares(residual, x0 / scale, bounds=(lower / scale, np.inf), diff_step=1e-3)
    err = np.abs(fit.x * scale - truth) / truth
    assert np.all(err < 0.03), dict(zip(names, err.round(4), strict=True))


@pytest.mark.parametrize("name", ROBOTS)
def test_replay_from_a_moving_start_with_earlier_commands(name: str) -> None:
    """Mid-log start: initial velocity and commands sent before t0 act as in simulate()."""
    spec = load_spec(name)
    v0, w0 = 0.5 * spec.max_v_mps, -0.4 * spec.max_w_radps
    cmd_t = np.arange(-1.0, 3.0, 0.1)
    cmd_v = np.where(cmd_t < 1.0, v0, -0.5 * spec.max_v_mps)
    cmd_w = np.where(cmd_t < 1.5, w0, 0.3 * spec.max_w_radps)
    t_out = np.arange(0.0, 3.0, 0.05)
    kw = {"cmd_t_s": cmd_t, "cmd_v": cmd_v, "cmd_w": cmd_w, "t_out_s": t_out, "v0": v0, "w0": w0}
    with PybulletRobot(spec) as bot:
        got = bot.replay(**kw)
    ref = simulate(spec.drive, spec.geometry, **kw)
    assert got.v[0] == pytest.approx(v0, abs=1e-6) and got.w[0] == pytest.approx(w0, abs=1e-6)
    # no start-up transient: until the new commands act, only the friction droop shows
    early = t_out < 0.5
    assert np.max(np.abs(got.v[early] - ref.v[early])) < 1e-3
    assert np.max(np.abs(got.w[early] - ref.w[early])) < 5e-3
    assert np.max(np.abs(got.v - ref.v)) < 0.01 and np.max(np.abs(got.w - ref.w)) < 0.05
    with pytest.raises(RobotsValueError, match="velocity"):
        PybulletRobot(spec).set_velocity(float("nan"), 0.0)
