"""A yaw rate read by the wheel encoders: every engine and the fit read the model's body rate
times the effective over the driver's track (:func:`robots.measurement.yaw_reading_factor`),
a gyro's is the body's.

A skid steer's treads slip sideways in a turn, so its body turns slower than its wheels say
(the effective track, ``track_factor`` x the geometric one). The encoders see the wheels, not
the slip: for the same wheel speeds they read the same yaw rate whatever the track factor.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robots.errors import RobotsValueError
from robots.measurement import yaw_reading_factor
from robots.params import DriveParams
from robots.reduced import DEFAULT_DT_S
from robots.spec import RobotSpec
from sim2real.agreement.replay import replay
from sim2real.logs import Trace
from sysid._coords import Mapper
from sysid._excitation import analyse
from sysid._logs import as_log_arrays
from sysid._problem import Problem
from tests.husky import husky_spec

T0_NS = 1_700_000_000_000_000_000
#: Track factors: a differential drive's, and two skid steers' slips.
CHIS = (1.0, 1.6, 2.2)


@pytest.fixture(scope="module")
def encoders(tmp_path_factory: pytest.TempPathFactory) -> RobotSpec:
    """A Husky-sized skid steer from ``robots new --drive skid`` (yaw rate from the wheels)."""
    spec = husky_spec(tmp_path_factory.mktemp("encoder_yaw"))
    assert spec.odometry.w_source == "wheels"
    return spec


def _gyro(spec: RobotSpec) -> RobotSpec:
    return dataclasses.replace(spec, odometry=dataclasses.replace(spec.odometry, w_source="imu"))


def _params(spec: RobotSpec, chi: float, driver: float = 1.0) -> DriveParams:
    """PI wheel loops that hold the wheels at the targets of a driver on ``driver`` x the
    geometric track: the wheel speeds of a held command do not depend on the track factor."""
    return spec.drive.replace(track_factor=chi, driver_track_factor=driver, speed_loop_ki_per_s=5.0)


def _trace(duration_s: float, cmd_w: float, meas_w0: float) -> Trace:
    """(0.3 m/s, ``cmd_w``) held; odometry at 20 Hz from t = 0. At rest (``meas_w0`` 0) the
    commands start at t = 0; else the log starts in that turn, reading (0.3 m/s, ``meas_w0``),
    under commands from t = -1 s (the replay and the fit start from the first reading; the
    others only give the times). A turn's readings jitter
    by 1e-6 so that they do not repeat exactly (a zero-order hold to the fit,
    :mod:`robots.measurement`)."""
    cmd_t = np.arange(-1.0 if meas_w0 else 0.0, duration_s, 0.1)
    meas_t = np.arange(0.0, duration_s, 0.05)
    jitter = 1e-6 * (-1.0) ** np.arange(meas_t.size) if meas_w0 else np.zeros(meas_t.size)
    meas_w = meas_w0 + jitter
    return Trace(
        cmd_t_ns=T0_NS + np.rint(cmd_t * 1e9).astype(np.int64),
        cmd_v=np.full(cmd_t.size, 0.3),
        cmd_w=np.full(cmd_t.size, cmd_w),
        meas_t_ns=T0_NS + np.rint(meas_t * 1e9).astype(np.int64),
        meas_v=(0.3 if meas_w0 else 0.0) + jitter,
        meas_w=meas_w,
    )


@pytest.mark.parametrize(
    "engine", ["reduced", "pybullet", pytest.param("mujoco", marks=pytest.mark.mujoco)]
)
def test_encoder_yaw_rate_does_not_see_the_slip(encoders: RobotSpec, engine: str) -> None:
    """(0.3 m/s, 0.6 rad/s) held 4 s, steady over the last second. Golden: the encoders read
    0.600 rad/s at every track factor, with a driver on the geometric track and with the
    Husky's (``wheel_separation_multiplier`` 1.875, which its odometry divides by too); the
    gyro 0.600 / 0.375 / 0.273 (0.6 / chi) and 1.125 / 0.703 / 0.511 (0.6 x 1.875 / chi),
    measured the same to 1e-3 in the three engines."""
    trace = _trace(4.0, 0.6, 0.0)
    geometric = [(chi, 1.0, 0.6 / chi) for chi in CHIS]
    husky = [(chi, 1.875, 1.125 / chi) for chi in CHIS]
    for chi, driver, body in geometric + husky:
        p = _params(encoders, chi, driver)
        read = replay(trace, robot=encoders, params=p, engine=engine)
        gyro = replay(trace, robot=_gyro(encoders), params=p, engine=engine)
        assert float(np.mean(read.w[-20:])) == pytest.approx(0.600, abs=1e-3), (chi, driver)
        assert float(np.mean(gyro.w[-20:])) == pytest.approx(body, abs=1e-3), (chi, driver)
        np.testing.assert_allclose(read.w, chi / driver * gyro.w, rtol=1e-12, atol=1e-12)
        np.testing.assert_array_equal(read.v, gyro.v)  # v is the same reading


def test_a_log_that_starts_turning_starts_at_its_encoder_reading(encoders: RobotSpec) -> None:
    """A log that starts in a steady turn, encoders reading 0.5 rad/s under a 0.5 rad/s
    command (no friction, so the loops' integral has nothing to hold): the replay starts the
    body at 0.5 / chi and reads 0.5 throughout."""
    trace = _trace(2.0, 0.5, 0.5)
    for chi in CHIS:
        p = _frictionless(_params(encoders, chi))
        sim = replay(trace, robot=encoders, params=p, engine="reduced")
        assert sim.w[0] == pytest.approx(0.5, abs=2e-6)
        np.testing.assert_allclose(sim.w, 0.5, atol=2e-3)


def _frictionless(p: DriveParams) -> DriveParams:
    return p.replace(
        coulomb_v_fwd_n=0.0, coulomb_v_bwd_n=0.0, coulomb_w_nm=0.0,
        viscous_v_ns_per_m=0.0, viscous_w_nms_per_rad=0.0,
    )  # fmt: skip


def _problem(trace: Trace, spec: RobotSpec) -> Problem:
    return Problem(
        [as_log_arrays(trace, 0)],
        Mapper(spec.geometry, spec.drive),
        (),
        {},
        scale_v=1.0,
        scale_w=1.0,
        dt_s=DEFAULT_DT_S,
        w_source=spec.odometry.w_source,
    )


def test_the_fit_reads_the_model_as_replay_does(encoders: RobotSpec) -> None:
    """sysid's problem (the fit's residuals) simulates what the reduced replay reads, for both
    sources, and several track factors in one compiled call (a Jacobian's columns) as one by
    one; a log that starts in a steady turn starts the body at its encoder reading / chi."""
    trace = _trace(3.0, 0.6, 0.0)
    for spec in (encoders, _gyro(encoders)):
        prob = _problem(trace, spec)
        rows = [_params(spec, chi) for chi in CHIS]
        for p in rows:
            (fit,) = prob.simulate(p)
            sim = replay(trace, robot=spec, params=p, engine="reduced")
            np.testing.assert_allclose(fit.w, sim.w, atol=1e-9)
        one_by_one = np.concatenate([prob.scaled_sim_many([p]) for p in rows])
        np.testing.assert_array_equal(prob.scaled_sim_many(rows), one_by_one)
    turning = _problem(_trace(2.0, 0.5, 0.5), encoders)
    rows = [_frictionless(_params(encoders, chi)) for chi in CHIS]
    for p, fit in zip(rows, turning.scaled_sim_many(rows), strict=True):
        w = fit[fit.size // 2 :]  # v then w
        np.testing.assert_allclose(w, 0.5, atol=2e-3, err_msg=f"chi {p.track_factor}")


@settings(max_examples=30, deadline=None)
@given(
    chi=st.floats(1.0, 4.0), driver=st.floats(1.0, 4.0), source=st.sampled_from(("imu", "wheels"))
)
def test_the_reading_factor(chi: float, driver: float, source: str) -> None:
    p = DriveParams(track_factor=chi, driver_track_factor=driver)
    factor = yaw_reading_factor(source, p)
    assert factor == pytest.approx(chi / driver if source == "wheels" else 1.0, rel=1e-15)
    # a differential drive: both read the same
    assert yaw_reading_factor(source, DriveParams()) == 1.0


def test_an_unknown_source_is_refused_in_one_sentence(encoders: RobotSpec) -> None:
    with pytest.raises(RobotsValueError, match=r"w_source must be one of .* got 'compass'"):
        yaw_reading_factor("compass", DriveParams())
    with pytest.raises(ValueError, match="w_source"):
        Problem([as_log_arrays(_trace(1.0, 0.0, 0.0), 0)], Mapper(encoders.geometry, DriveParams()),
                (), {}, scale_v=1.0, scale_w=1.0, dt_s=0.01, w_source="odom")  # fmt: skip


def _teleop() -> Trace:
    """12 s of (v, w) commands held 1 s each, seeded; odometry at rest (only its times)."""
    rng = np.random.default_rng(3)
    cmd_t = np.arange(0.0, 12.0, 0.1)
    steps = np.repeat(rng.uniform(-1.0, 1.0, (12, 2)), 10, axis=0)
    meas_t = np.arange(0.0, 12.0, 0.05)
    return Trace(
        cmd_t_ns=T0_NS + np.rint(cmd_t * 1e9).astype(np.int64),
        cmd_v=0.5 * steps[:, 0],
        cmd_w=steps[:, 1],
        meas_t_ns=T0_NS + np.rint(meas_t * 1e9).astype(np.int64),
        meas_v=np.zeros(meas_t.size),
        meas_w=np.zeros(meas_t.size),
    )


def test_encoder_yaw_cannot_tell_the_slip_from_the_yaw_inertia(encoders: RobotSpec) -> None:
    """With the yaw rate read by the encoders, track factor chi, yaw inertia I and viscous yaw
    friction b act as (1, I / chi, b / chi): a teleop-like run reads the same to 1e-9 rad/s,
    so ``sysid fit`` leaves chi at its prior (:data:`sysid._excitation.ENCODER_YAW_NOTE`).
    The gyro tells them apart (measured: up to 0.386 rad/s)."""
    trace = _teleop()
    geo = encoders.geometry
    slip = _params(encoders, 1.5, 1.2).replace(viscous_w_nms_per_rad=3.0)
    inertia = slip.total_yaw_inertia_kgm2(geo) / 1.5
    rolling = slip.replace(
        track_factor=1.0,
        added_yaw_inertia_kgm2=inertia - geo.yaw_inertia_kgm2,
        viscous_w_nms_per_rad=3.0 / 1.5,
    )
    a, b = (replay(trace, robot=encoders, params=p, engine="reduced") for p in (slip, rolling))
    assert np.max(np.abs(a.w)) > 0.5  # it turns
    np.testing.assert_allclose(a.w, b.w, atol=1e-9)
    np.testing.assert_allclose(a.v, b.v, atol=1e-9)
    gyro = [
        replay(trace, robot=_gyro(encoders), params=p, engine="reduced") for p in (slip, rolling)
    ]
    assert np.max(np.abs(gyro[0].w - gyro[1].w)) > 0.3


def test_the_fit_leaves_the_track_factor_to_its_prior_under_encoder_yaw(
    encoders: RobotSpec,
) -> None:
    """``"auto"`` frees the skid steer's track factor against its prior for a gyro's yaw rate
    and leaves it at the prior, with a note, for the encoders'."""
    simulated = replay(_teleop(), robot=encoders, params=encoders.drive, engine="reduced")
    log = as_log_arrays(dataclasses.replace(_teleop(), meas_v=simulated.v, meas_w=simulated.w), 0)
    informative = {n for n, p in encoders.priors.items() if p.informative}
    assert "track_factor" in informative
    gyro = analyse([log], encoders.geometry, encoders.drive, "auto", informative)
    read = analyse([log], encoders.geometry, encoders.drive, "auto", informative, encoder_yaw=True)
    assert "track_factor" in gyro.free and "track_factor" not in read.free
    assert set(gyro.free) - set(read.free) == {"track_factor"}
    assert [n for n in read.warnings if n.startswith("track_factor is kept at its prior 1.6")]


def test_the_pybullet_robot_odometry_reads_the_encoders(encoders: RobotSpec) -> None:
    """The pybullet robot's own odometry (what an env observes) reads the encoders as replay
    does: 0.600 rad/s under the held command at chi 1.6 (body 0.375), the gyro spec 0.375."""
    from robots.pybullet_robot import PybulletRobot

    p = _params(encoders, 1.6)
    for spec, want in ((encoders, 0.600), (_gyro(encoders), 0.375)):
        with PybulletRobot(spec, params=p) as robot:
            for _ in range(40):
                robot.step(0.3, 0.6, 0.1)
            _, odom_w = robot.odometry()
            assert odom_w == pytest.approx(want, abs=1e-3)
            assert robot.velocity[1] == pytest.approx(0.375, abs=1e-3)
            out = robot.replay(
                cmd_t_s=np.array([0.0]), cmd_v=np.array([0.3]), cmd_w=np.array([0.6]),
                t_out_s=np.arange(0.0, 4.0, 0.1),
            )  # fmt: skip
            assert float(out.odom_w[-1]) == pytest.approx(want, abs=1e-3)
