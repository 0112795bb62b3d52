"""Honest diagnostics: interval coverage on plants drawn from the priors, and every written
result loads into the pybullet robot (every shipped robot, plants of 0.5x-3x the spec mass)."""

from __future__ import annotations

import collections
import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from robots import list_robots
from robots.params import DriveParams, load_drive_params
from robots.randomization import DriveDistribution
from robots.spec import load_spec
from sysid import fit_drive
from sysid.synthetic import step_commands, synthetic_log
from tests.processes import map_in_processes

#: (seed, plants) of the plants' truths and logs. 29 and 47 were looked at while the fit's
#: starts were designed (sysid._map.restarts, released_start); 61 and 73 were first run after
#: it, as a check. ``benchmarks/bench_sysid_coverage.py`` fits all 120 and prints every field's
#: coverage per seed and pooled (binomial sd ~3 points at 90 %), against
#: :data:`COVERAGE_FIELD`. Measured: lowest Coulomb w 104/120 (0.866), wheel speed cap 105/120,
#: integral gain 106/120 (its misses are near misses, |t| 2-2.3, a truth at its bound 0, and
#: plants whose log prefers an integral gain near 0 by a likelihood ratio of ~e^9), every other
#: field >= 0.89; pooled over every field 0.928 (Wilson 95 % 0.914-0.939).
ALL_PLANT_SEEDS = ((29, 24), (47, 48), (61, 24), (73, 24))
#: The pooled coverage each field must reach in the benchmark's 120 plants.
COVERAGE_FIELD = 0.85
#: The test's plants: seed 61's 24, none of them looked at while the starts were designed.
TEST_PLANT_SEEDS = ((61, 24),)
#: Each fitted field's 95 % interval must hold the truth on at least this many of the test's 24
#: plants (0.75; measured on seed 61: lowest 20, the wheel speed cap). Binomial, per field: a
#: false alarm 3.4 % at the lowest field's 0.866 of the 120 plants, 1.7 % at the integral
#: gain's 0.883, 0.01 % at the nominal 0.95; a field whose intervals are half as wide as they
#: should be (coverage ~2/3 for a normal error) fails with probability 0.74, one covering half
#: the time 0.99. The 0.85 of :data:`COVERAGE_FIELD` needs the benchmark's 120 plants: on 24
#: it would be a false alarm 40 % of the time at the lowest field's coverage.
MIN_COVERED_FIELD = 18
#: Pooled over every fitted field of the test's plants (14 per plant, 336 intervals; measured
#: 315, 0.9375) the intervals must hold the truth at least this often: intervals narrowed by
#: 0.7 in every direction (coverage ~0.83 for a normal error) fail it with probability 0.99, a
#: false alarm at the 120 plants' 0.928 is 0.07 % (binomial; the fields of one plant are
#: correlated, which widens both). A single field is :data:`MIN_COVERED_FIELD`'s to catch.
COVERAGE_POOLED = 0.88
#: Limits without a prior (the spec says "no limit") may still be fitted when a log seems to
#: show one; on these plants (truth: no limit) at most this share of the two acceleration
#: limits x plants is claimed (measured 8 of 48 on seed 61, 46 of 240 on the benchmark's 120):
#: an open problem, reported.
SPURIOUS_LIMITS = 0.25


def plant_cases(seeds: tuple[tuple[int, int], ...]) -> list[tuple[DriveParams, int]]:
    """(truth, log seed) of the plants of ``seeds`` ((plant seed, plants) pairs), each truth
    drawn from the ``turtlebot3_burger`` spec's priors."""
    spec = load_spec("turtlebot3_burger")
    prior = DriveDistribution.from_priors(spec.name, spec.geometry, spec.priors, session=False)
    cases = []
    for plant_seed, n_plants in seeds:
        truths = prior.sample(np.random.default_rng(plant_seed), n_plants)
        cases += [(truth, 100 * plant_seed + i) for i, truth in enumerate(truths)]
    return cases


def fit_plant(
    case: tuple[DriveParams, int],
) -> tuple[float, list[tuple[str, float, float | None, float | None]]]:
    """One plant's fit (a worker process): its total mass and, per fitted field, (name, truth,
    95 % interval low, high)."""
    truth, seed = case
    spec = load_spec("turtlebot3_burger")
    geo = spec.geometry
    t, v, w = step_commands(20.0, seed=seed, v_max_mps=0.2, w_max_radps=1.5)
    log = synthetic_log(truth, geo, cmd_t_s=t, cmd_v=v, cmd_w=w, seed=seed, spike_mps=None)
    res = fit_drive(
        [log],
        geometry=geo,
        base_params=spec.drive,
        priors=spec.priors,
        odom_v_window_s=0.02,
    )
    fitted = []
    for e in res.estimates:
        if e.status != "fitted":
            continue
        fitted.append((e.name, float(getattr(truth, e.name)), e.ci95_low, e.ci95_high))
    return res.params.total_mass_kg(geo), fitted


@pytest.mark.slow
def test_95_percent_intervals_cover_plants_drawn_from_the_priors() -> None:
    hits: collections.Counter[str] = collections.Counter()
    fits: collections.Counter[str] = collections.Counter()
    spurious = 0
    # the fits are independent: one worker process per core (~3.5 s of CPU each)
    for total_mass_kg, fitted in map_in_processes(fit_plant, plant_cases(TEST_PLANT_SEEDS)):
        assert total_mass_kg > 0
        for name, truth_value, low, high in fitted:
            if math.isinf(truth_value):
                spurious += 1
                continue
            assert low is not None and high is not None
            fits[name] += 1
            hits[name] += low <= truth_value <= high
    n_plants = sum(n for _, n in TEST_PLANT_SEEDS)
    assert {"delay_s", "added_mass_kg", "motor_gain_nms_per_rad", "coulomb_v_fwd_n"} <= set(fits)
    assert sum(fits.values()) >= 12 * n_plants  # every plant fits most fields
    for name, n_fits in fits.items():
        # a field fitted on few plants (the rest at a bound) is judged on the plants it has
        assert hits[name] >= MIN_COVERED_FIELD * n_fits / n_plants, (name, hits, fits)
    assert sum(hits.values()) >= COVERAGE_POOLED * sum(fits.values()), (hits, fits)
    assert spurious <= SPURIOUS_LIMITS * 2 * n_plants, spurious


#: Plant 0 of seed 29 as the sampler drew it before it used the covariance's principal root
#: (robots.randomization), kept because a one-start fit of it ends in a local minimum.
RESTART_PLANT = {
    "delay_s": 0.05500927020094071,
    "speed_lim_v_mps": 0.2192621746978913,
    "speed_lim_w_radps": 2.8306326809993503,
    "wheel_speed_max_radps": 7.107746057875493,
    "motor_gain_nms_per_rad": 0.003517896179182786,
    "speed_loop_ki_per_s": 0.0,
    "wheel_torque_max_nm": 0.052794532344308774,
    "coulomb_v_fwd_n": 0.14453841588873306,
    "coulomb_v_bwd_n": 0.0926660709796348,
    "coulomb_w_nm": 0.01074880602285018,
    "viscous_v_ns_per_m": 0.0,
    "viscous_w_nms_per_rad": 0.0008243904742183464,
    "added_mass_kg": 0.09248382869670069,
    "added_yaw_inertia_kgm2": -0.000498513752143047,
}


def test_restarts_free_a_delay_pinned_at_zero() -> None:
    """Plant 0 of seed 29 (:data:`RESTART_PLANT`): from the one start the fit pinned the delay at 0 (truth 0.055 s,
    the objective 2.5x the truth's) with an interval 6 sd away; the prior-mean start finds it."""
    spec = load_spec("turtlebot3_burger")
    geo = spec.geometry
    truth = spec.drive.replace(**RESTART_PLANT)
    seed = 100 * 29
    t, v, w = step_commands(20.0, seed=seed, v_max_mps=0.2, w_max_radps=1.5)
    log = synthetic_log(truth, geo, cmd_t_s=t, cmd_v=v, cmd_w=w, seed=seed, spike_mps=None)
    res = fit_drive(
        [log], geometry=geo, base_params=spec.drive, priors=spec.priors, odom_v_window_s=0.02
    )
    delay = next(e for e in res.estimates if e.name == "delay_s")
    assert truth.delay_s == pytest.approx(0.055, abs=5e-4)
    assert delay.ci95_low is not None and delay.ci95_high is not None
    assert delay.ci95_low <= truth.delay_s <= delay.ci95_high
    assert delay.value > 0.03


@pytest.mark.slow
@pytest.mark.parametrize("robot", list_robots())
@pytest.mark.parametrize("mass_factor", [0.5, 3.0])
def test_every_written_result_loads_into_pybullet(
    robot: str, mass_factor: float, tmp_path: Path
) -> None:
    from robots.pybullet_robot import PybulletRobot

    spec = load_spec(robot)
    geo = spec.geometry
    truth = spec.drive.replace(
        delay_s=0.1,
        added_mass_kg=(mass_factor - 1.0) * geo.mass_kg,
        added_yaw_inertia_kgm2=(mass_factor - 1.0) * geo.yaw_inertia_kgm2,
    )
    t, v, w = step_commands(15.0, seed=3, v_max_mps=0.6 * spec.max_v_mps, w_max_radps=1.0)
    log = synthetic_log(truth, geo, cmd_t_s=t, cmd_v=v, cmd_w=w, seed=3, spike_mps=None)
    res = fit_drive(
        [log], geometry=geo, base_params=spec.drive, priors=spec.priors, robot=spec.name
    )
    path = res.save(tmp_path / "params.yaml")
    params = load_drive_params(path, robot=spec.name, base=spec.drive)
    assert params.total_mass_kg(geo) > 0 and params.total_yaw_inertia_kgm2(geo) > 0
    bot = PybulletRobot(spec, params=params)
    try:
        bot.step(0.1, 0.2, 0.1)
        draws = DriveDistribution.from_params_file(path, robot=spec.name).sample(
            np.random.default_rng(0), 3, spread=2.0
        )
        for p in draws:
            PybulletRobot(spec, params=p, client=bot.client).step(0.1, 0.0, 0.05)
    finally:
        bot.close()


#: Plant 27 of seed 47 (its values, so a sampler change cannot move it): torque-limited
#: transients, no acceleration limit. Re-drawn when friction became per unit mass (the same
#: draw: only the five friction values moved, by 1-15 %); the previous draw's values
#: (e.g. coulomb_w_nm 0.0339) now end in a third basin from every start, a multimodality this
#: test does not cover (on the 48 plants of seed 47 the released start rescues 4 integral
#: gains, plant 27 among them, and loses none).
RELEASED_PLANT = {
    "delay_s": 0.1491290728193102,
    "speed_lim_v_mps": 0.2103875892092706,
    "speed_lim_w_radps": 2.8866802501366737,
    "wheel_speed_max_radps": 6.723785906608241,
    "motor_gain_nms_per_rad": 0.011631531730047363,
    "speed_loop_ki_per_s": 18.669429757944677,
    "wheel_torque_max_nm": 0.04380935992512276,
    "coulomb_v_fwd_n": 0.20457904898978985,
    "coulomb_v_bwd_n": 0.45027503006382064,
    "coulomb_w_nm": 0.028945816326570863,
    "viscous_v_ns_per_m": 0.6554086235685908,
    "viscous_w_nms_per_rad": 0.0036965059918621654,
    "added_mass_kg": 0.013745946655507435,
    "added_yaw_inertia_kgm2": -0.0004095981959793219,
}


@pytest.mark.parametrize("released", [True, False])
def test_released_start_finds_torque_limited_transients(
    released: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """:data:`RELEASED_PLANT`: from the spec's start (an acceleration limit at the smoothed
    peak, the spec's torque cap) the fit explains the torque-limited transients by a limit and
    an integral gain of 8.9 /s (truth 18.7, outside its interval; 7.3 /s before friction
    became per unit mass);
    the torque-cap restart (sysid._map._RESTART_SDS) reaches the truth's basin."""
    import sysid._map

    if not released:  # the starts as they were before (the failure this test guards)
        monkeypatch.setattr(sysid._map, "released_start", lambda *a, **k: None)
        monkeypatch.setattr(
            sysid._map, "_RESTART_SDS", {"speed_loop_ki_per_s": (-1.5, 1.5), "delay_s": (0.0,)}
        )
    spec = load_spec("turtlebot3_burger")
    geo = spec.geometry
    truth = spec.drive.replace(**RELEASED_PLANT)
    seed = 100 * 47 + 27
    t, v, w = step_commands(20.0, seed=seed, v_max_mps=0.2, w_max_radps=1.5)
    log = synthetic_log(truth, geo, cmd_t_s=t, cmd_v=v, cmd_w=w, seed=seed, spike_mps=None)
    # the plant was drawn from the torque cap's earlier prior (log-sd 0.5); the spec's is now
    # 0.3 and puts this cap (0.54x nominal) 2 sd low, where the prior itself pulls the fit off
    # the truth (k_i 16.7 /s, interval 15.0-18.3): this test is about the fit's starts, so it
    # keeps the prior the plant came from (no 48-plant draw of the new prior has a transient
    # that only the released start finds: 41 of 48 integral gains covered with or without it)
    priors = dict(spec.priors)
    priors["wheel_torque_max_nm"] = dataclasses.replace(priors["wheel_torque_max_nm"], sd=0.5)
    res = fit_drive(
        [log], geometry=geo, base_params=spec.drive, priors=priors, odom_v_window_s=0.02
    )
    ki = res.estimate("speed_loop_ki_per_s")
    assert ki.ci95_low is not None and ki.ci95_high is not None
    miss = abs(ki.value - truth.speed_loop_ki_per_s)
    if released:  # the truth's basin, within 3 sd (the 95 % bound moves by a few hundredths of
        # 1/s with the CPU's floating point, and the truth sits near it)
        assert miss < 3.0 and miss <= 3.0 * ki.std, ki
    else:  # the limit's basin, its interval clear of the truth
        assert miss >= 3.0 and not ki.ci95_low <= truth.speed_loop_ki_per_s <= ki.ci95_high, ki
