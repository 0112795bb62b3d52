"""The plant driven command by command (sim2real.plants.closed_loop): the batch physics exactly."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sim2real.errors import Sim2RealValueError
from sim2real.plants import diff_drive
from sim2real.plants.closed_loop import PlantSessions, PlantStepper, as_plant_sessions
from sim2real.plants.diff_drive import SessionVariation, plant_from_spec

ROBOT = "turtlebot3_burger"


def _batch_true_velocity(
    p: diff_drive.PlantParams, cmd: np.ndarray, dt_s: float, at_t: np.ndarray
) -> np.ndarray:
    """(v, w) at ``at_t`` of one batch integration with every command known in advance."""
    t = dt_s * np.arange(cmd.shape[0])
    arrival = np.maximum.accumulate(t + max(p.latency_s, 0.002))
    out = np.zeros((at_t.size, 4))
    diff_drive._kernel(
        diff_drive._pack(p),
        arrival,
        cmd[:, 0].copy(),
        cmd[:, 1].copy(),
        at_t,
        p.physics_dt_s,
        1.0 / p.control_rate_hz,
        out,
        diff_drive._fresh_state(),
    )
    return out[:, :2]


@settings(max_examples=8, deadline=None)
@given(seed=st.integers(0, 2**16), dt_s=st.sampled_from([0.05, 0.1, 0.137]))
def test_stepping_integrates_exactly_what_a_batch_run_does(seed: int, dt_s: float) -> None:
    p = plant_from_spec(ROBOT, latency_jitter_s=0.0)
    rng = np.random.default_rng(seed)
    cmd = rng.uniform([-0.25, -3.0], [0.25, 3.0], (60, 2))  # beyond the clamps too
    stepper = PlantStepper(p, np.random.default_rng(seed))
    got = [np.column_stack(stepper.step(v, w, dt_s)) for v, w in cmd]
    samples = np.concatenate(got)
    want = _batch_true_velocity(p, cmd, dt_s, samples[:, 0].copy())
    np.testing.assert_array_equal(samples[:, 1:], want)
    assert stepper.time_s == pytest.approx(60 * dt_s, abs=1e-9)


def test_odometry_reports_the_commanded_speed_after_the_latency() -> None:
    p = plant_from_spec(ROBOT, latency_s=0.15, latency_jitter_s=0.0, gyro_bias_radps=0.0)
    stepper = PlantStepper(p, np.random.default_rng(0))
    stepper.step(0.2, 0.5, 0.1)
    assert stepper.odometry[0] == 0.0 and stepper.true_velocity == (0.0, 0.0)  # not arrived
    for _ in range(49):
        stepper.step(0.2, 0.5, 0.1)
    v, w = stepper.odometry
    # the PI loops remove the friction error; v is quantised by the encoders (4096 ticks/rev)
    tick_v = 2.0 * math.pi / 4096 * p.wheel_radius_m * p.odom_rate_hz
    assert abs(v - 0.2) <= tick_v and abs(w - 0.5) < 4 * p.gyro_noise_radps
    assert stepper.true_velocity == pytest.approx((0.2, 0.5), abs=2e-3)


def test_silence_beyond_the_command_timeout_stops_the_base() -> None:
    p = plant_from_spec(ROBOT, latency_jitter_s=0.0, cmd_timeout_s=0.5)
    stepper = PlantStepper(p, np.random.default_rng(0))
    for _ in range(20):
        stepper.step(0.2, 0.0, 0.1)
    assert stepper.true_velocity[0] > 0.19
    stepper.step(0.2, 0.0, 3.0)  # one command, then nothing for 3 s
    assert abs(stepper.true_velocity[0]) < 1e-3


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_same_seed_same_session_and_numbers(seed: int) -> None:
    sessions = PlantSessions.of(ROBOT)
    runs = []
    for _ in range(2):
        rng = np.random.default_rng(seed)
        stepper = PlantStepper(sessions.draw(rng), rng)
        runs.append([stepper.step(0.2, 0.3, 0.1)[1][-1] for _ in range(10)] + [stepper.odometry])
    assert runs[0] == runs[1]
    other = PlantSessions.of(ROBOT).draw(np.random.default_rng(seed + 1))
    assert other != sessions.draw(np.random.default_rng(seed))


def test_sessions_fixed_or_drawn_and_their_robot() -> None:
    fixed = PlantSessions.of(ROBOT, variation=None)
    rng = np.random.default_rng(0)
    assert fixed.draw(rng) is fixed.base and fixed.robot == ROBOT
    narrow = PlantSessions.of(ROBOT, variation=SessionVariation(payload_fraction=(0.5, 0.5)))
    assert narrow.draw(rng).mass_kg == pytest.approx(1.5 * narrow.base.mass_kg)
    assert as_plant_sessions(None, ROBOT).variation == SessionVariation()
    assert as_plant_sessions(fixed.base, ROBOT).variation is None


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: as_plant_sessions(PlantSessions.of("turtlebot2"), ROBOT), "robot 'turtlebot2'"),
        (lambda: as_plant_sessions("fast", ROBOT), "must be a sim2real.plants.PlantSessions"),
        (lambda: PlantSessions(base="x"), "PlantSessions.base must be a PlantParams"),  # type: ignore[arg-type]
        (
            lambda: PlantStepper(plant_from_spec(ROBOT), np.random.default_rng(), substep_s=0),
            "substep_s",
        ),
        (
            lambda: PlantStepper(plant_from_spec(ROBOT), np.random.default_rng()).step(0, 0, -1),
            "duration_s",
        ),
        (
            lambda: PlantStepper(plant_from_spec(ROBOT), np.random.default_rng()).step(
                math.nan, 0, 1
            ),
            "finite",
        ),
    ],
)
def test_bad_input_is_one_sentence(call: object, match: str) -> None:
    with pytest.raises(Sim2RealValueError, match=match):
        call()  # type: ignore[operator]
