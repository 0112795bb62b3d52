"""The foreign skid-steer plant and issue 12's skid target.

Target: on a synthetic skid steer with slip, the fit with the skid fields reaches agreement
>= 0.9 on a held-out session where the plain differential-drive fit stays below 0.7.

"The plain differential-drive fit" is what a user gets without the skid fields: the spec
``sim2real robots new husky --drive diff`` writes from the Husky A200's published numbers
(geometric track, ``track_factor`` 1 with prior sd 0, the differential drive's scrub prior),
with the robot's real driver settings written in as the user knows them
(``husky_control/config/control.yaml``: ``cmd_vel_timeout`` 0.25 s, 3.0 m/s^2, 6.0 rad/s^2 and
``wheel_separation_multiplier`` 1.875, a driver setting, not a slip model), everything else
fitted by ``sysid`` against the spec's priors. The skid fit is the same from
``robots new --drive skid`` (``track_factor`` fitted).
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from robots.params import DriveParams, Prior
from robots.spec import RobotSpec
from sim2real.agreement.figures import measure_agreement
from sim2real.agreement.replay import replay
from sim2real.errors import Sim2RealValueError
from sim2real.plants.skid import (
    CHI_RANGE,
    MU_RANGE,
    SkidPlantParams,
    effective_track_factor,
    husky_like,
    make_skid_sessions,
    plant_odometry,
    run_skid_plant,
    skid_robot,
)
from sysid.fit import fit_drive
from tests.husky import husky_spec
from tests.processes import map_in_processes


def _husky_spec(folder: Path, drive_type: str) -> RobotSpec:
    """The Husky's spec as ``robots new --drive DRIVE_TYPE`` writes it, with its driver's
    published settings."""
    spec = plant_odometry(husky_spec(folder, drive=drive_type))  # the plant's yaw rate is a gyro's
    drive = spec.drive.replace(
        cmd_timeout_s=0.25, accel_lim_v_mps2=3.0, accel_lim_w_radps2=6.0, driver_track_factor=1.875
    )
    return dataclasses.replace(spec, drive=drive)


@pytest.fixture(scope="module")
def husky(tmp_path_factory: pytest.TempPathFactory) -> RobotSpec:
    return _husky_spec(tmp_path_factory.mktemp("skidplant"), "skid")


@pytest.fixture(scope="module")
def husky_diff(tmp_path_factory: pytest.TempPathFactory) -> RobotSpec:
    spec = _husky_spec(tmp_path_factory.mktemp("diffplant"), "diff")
    assert spec.drive.track_factor == 1.0 and spec.priors["track_factor"].sd == 0.0
    return spec


def _fixed(spec: RobotSpec, **values: float) -> dict[str, Prior]:
    priors = dict(spec.priors)
    for name, value in values.items():
        priors[name] = Prior(name=name, nominal=value, sd=0.0, session_sd=0.0, source="spec")
    return priors


def test_the_slip_comes_out_of_the_tyres() -> None:
    """A steady turn's wheel speeds imply a track ~1.5 x the geometric one (Clearpath
    calibrates the Jackal's driver to 1.5 and the Husky's to 1.875)."""
    p = husky_like()
    chi = effective_track_factor(p, 0.0, 1.0)
    assert 1.3 < chi < 1.9
    # stiffer lateral grip (slip_lat smaller) scrubs harder and slips more
    assert effective_track_factor(p.replace(slip_lat_mps=0.04), 0.0, 1.0) > chi + 0.2
    # the driver's 1.875 turns the base faster than a geometric-track driver would: the PI
    # loops hold the wheels at their targets, so the base turns at w x 1.875 / chi (measured
    # 1.836 rad/s for 1.5); proportional loops droop under the scrub to ~3/4 of that
    # (measured 1.392 rad/s), a droop a differential model's yaw friction can imitate
    t = np.arange(0.0, 5.0, 0.1)
    quiet = p.replace(gyro_noise_radps=0.0, gyro_bias_radps=0.0, v_noise_mps=0.0)
    steady = []
    for plant in (quiet, quiet.replace(ki_nm_per_rad=0.0)):
        tr = run_skid_plant(
            plant,
            t,
            np.zeros(t.size),
            np.full(t.size, 1.5),
            duration_s=5.0,
            rng=np.random.default_rng(0),
        )
        steady.append(float(np.mean(tr.meas_w[-50:])))
    assert steady[0] == pytest.approx(1.5 * 1.875 / chi, rel=0.01), steady
    assert 0.65 < steady[1] / steady[0] < 0.85, steady


def test_sessions_are_seeded_and_bad_input_is_refused() -> None:
    a = make_skid_sessions(husky_like(), 2, seed=5, duration_s=8.0)
    b = make_skid_sessions(husky_like(), 1, seed=5, duration_s=8.0)
    assert np.array_equal(a[0].meas_w, b[0].meas_w) and not np.array_equal(
        a[0].meas_w[:100], a[1].meas_w[:100]
    )
    with pytest.raises(Sim2RealValueError, match="n_sessions"):
        make_skid_sessions(husky_like(), 0, seed=0)
    with pytest.raises(Sim2RealValueError, match="mu"):
        husky_like().replace(mu=-1.0)


#: Seeds of :func:`skid_robot` and its sessions that no design choice was tuned on (the plant's
#: ranges and the fit's track-factor restarts were chosen on seeds 1-13 and 21-30): ten are
#: measured by ``benchmarks/bench_skid.py``.
TARGET_SEEDS = tuple(range(101, 111))
#: Of those, the seed with the smallest margin of the skid fit over the differential fit.
MARGIN_SEED = 105
#: Of those, a seed that meets the issue's target in full.
TARGET_SEED = 108


def test_skid_robots_span_the_published_slip() -> None:
    """Each seed is one robot on one ground: slip in CHI_RANGE, friction in MU_RANGE."""
    chis = [effective_track_factor(skid_robot(s), 0.0, 1.0) for s in TARGET_SEEDS]
    assert all(CHI_RANGE[0] - 0.01 <= c <= CHI_RANGE[1] + 0.01 for c in chis), chis
    assert max(chis) - min(chis) > 0.1  # the seeds differ
    assert all(MU_RANGE[0] <= skid_robot(s).mu <= MU_RANGE[1] for s in TARGET_SEEDS)
    assert skid_robot(101) == skid_robot(101)
    with pytest.raises(Sim2RealValueError, match="ground_sd"):
        make_skid_sessions(husky_like(), 1, seed=0, ground_sd=-0.1)


#: One fit of :func:`_fit_and_score`: the plant, the seed of its sessions, their duration (s),
#: the spec fitted and the engines the held-out session is replayed in.
FitCase = tuple[SkidPlantParams, int, float, RobotSpec, tuple[str, ...]]


def _fit_and_score(case: FitCase) -> tuple[list[float], DriveParams, float]:
    """Fit the plant's first teleop session with the spec (the driver's track factor fixed;
    run in a worker process): the held-out session's agreement in each engine, the fitted
    parameters and the fit's final cost."""
    plant, seed, duration_s, spec, engines = case
    fit_log, held_out = make_skid_sessions(
        plant, 2, seed=seed, duration_s=duration_s, profile="teleop"
    )
    priors = _fixed(spec, driver_track_factor=1.875)
    result = fit_drive(
        [fit_log],
        geometry=spec.geometry,
        base_params=spec.drive,
        priors=priors,
        w_source=spec.odometry.w_source,
    )
    scores = []
    for engine in engines:
        sim = replay(held_out, robot=spec, params=result.params, engine=engine)
        scores.append(measure_agreement(held_out, sim).agreement)
    return scores, result.params, result.settings["cost"]


@pytest.mark.slow
def test_skid_fit_beats_the_differential_fit(husky: RobotSpec, husky_diff: RobotSpec) -> None:
    """Seed 105 (:data:`MARGIN_SEED`): one robot on one ground (:func:`skid_robot`); fit one
    90 s teleop session (the driver's top speed and yaw rate), measure on another day's session.

    The issue's target in full (skid >= 0.9 where the plain differential fit < 0.7) holds on
    2 of 10 seeds (101, 108; :func:`test_the_issue_target_in_full_on_one_plant`) and on 1 of 5
    sessions of the canonical :func:`husky_like`: the skid half holds on all ten seeds, but the
    plain differential fit (module docstring) stays at 0.70-0.81 on the other eight. So this
    asserts the skid half, the fitted slip within 0.06 of the plant's, and a margin of 0.1 over
    the differential fit, on the seed whose margin is the smallest of the ten (each seed is
    one plant and one pair of sessions; ``benchmarks/bench_skid.py`` runs all ten).
    Measured (skid, diff) with the PI wheel loops of :func:`husky_like`: 101 (0.928, 0.604),
    102 (0.919, 0.783), 103 (0.955, 0.794), 104 (0.931, 0.719), 105 (0.933, 0.814); on seeds
    106-110 skid 0.904-0.952, diff 0.499-0.783; the margin is 0.119-0.411 on all ten, the
    fitted chi within 0.025 of the plant's; :func:`husky_like` with command seeds 0-4: skid
    0.882-0.951, diff 0.674-0.739 (``benchmarks/bench_skid.py``). The differential model
    cannot turn the base at the skid's w x 1.875 / chi with loops that hold the wheel speeds:
    its fit drops the integral term (k_i ~ 0) and droops the yaw with friction, which
    mis-models v. With proportional plant loops that droop is the plant's own and the
    differential fit matched the skid fit (101: 0.951 vs 0.947). The worst skid fits
    (husky_like sessions 3 and 4: 0.882, 0.887; seed 106: 0.904) lose 7-10 points within
    0.5 s of a command change, mostly v while braking (the model slows later than the plant,
    by 0.07-0.13 m/s on the missed samples) and w after yaw-rate steps; steady turns and
    straights miss at most 2.5 % of the samples. Since sysid compares its candidate fits on
    the final objective (:func:`sysid._map._final_choice`), relative changes of 1e-7 to 1e-5
    of seed 101's lateral tyre stiffness move its skid fit 0.925-0.929 (before 0.885-0.924).
    The differential fit's own re-balance is a five-step polish: run to convergence it gives
    101 0.738, 108 0.644 (the target's contrast holds on 108 alone then)."""
    seed = MARGIN_SEED
    # the two fits are independent: one worker process per core
    cases = [(skid_robot(seed), seed, 90.0, spec, ("reduced",)) for spec in (husky, husky_diff)]
    ([skid_score], skid_params, _), ([diff_score], diff_params, _) = map_in_processes(
        _fit_and_score, cases
    )
    chi = effective_track_factor(skid_robot(seed), 0.0, 1.0)
    assert skid_params.track_factor == pytest.approx(chi, abs=0.06)
    assert diff_params.track_factor == 1.0
    assert skid_score >= 0.9 and skid_score >= diff_score + 0.1, (skid_score, diff_score)
    held_out = make_skid_sessions(
        skid_robot(seed), 2, seed=seed, duration_s=90.0, profile="teleop"
    )[1]
    # the pybullet engine with the same fit agrees with the reduced one on the log
    sim_pb = replay(held_out, robot=husky, params=skid_params, engine="pybullet")
    sim_red = replay(held_out, robot=husky, params=skid_params, engine="reduced")
    assert np.sqrt(np.mean((sim_pb.v - sim_red.v) ** 2)) < 0.005
    assert np.sqrt(np.mean((sim_pb.w - sim_red.w) ** 2)) < 0.02
    assert measure_agreement(held_out, sim_pb).agreement > diff_score + 0.1


@pytest.mark.slow
def test_the_issue_target_in_full_on_one_plant(husky: RobotSpec, husky_diff: RobotSpec) -> None:
    """Issue 12's target as worded: a synthetic skid-steer plant with slip on which the skid
    fit agrees >= 0.9 on a held-out session where the plain differential fit stays below 0.7.

    Seed 108 (:data:`TARGET_SEED`: slip 1.55, mu 0.76; one of the ten bench seeds, none tuned
    on): measured skid 0.910, diff 0.499 in both engines (0.644 with the differential fit's
    re-balance run to convergence, so the contrast does not hang on that polish). On 8 of the
    10 seeds the differential fit reaches 0.70-0.81 while the skid fit stays >= 0.9
    (:func:`test_skid_fit_beats_the_differential_fit`, ``benchmarks/bench_skid.py``)."""
    seed = TARGET_SEED
    engines = ("reduced", "pybullet")
    cases = [(skid_robot(seed), seed, 90.0, spec, engines) for spec in (husky, husky_diff)]
    (skid_scores, skid_params, _), (diff_scores, diff_params, _) = map_in_processes(
        _fit_and_score, cases
    )
    chi = effective_track_factor(skid_robot(seed), 0.0, 1.0)
    assert skid_params.track_factor == pytest.approx(chi, abs=0.06)
    assert diff_params.track_factor == 1.0
    assert min(skid_scores) >= 0.9 and max(diff_scores) < 0.7, (skid_scores, diff_scores)


def test_the_track_factor_restarts_escape_a_worse_local_minimum(
    husky: RobotSpec, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Session 0 of seed 23 (a tuning seed) on the plant with proportional wheel loops. Under
    the prior weight estimated at the start point (w_p 2.9 there, 0.56 at the solution) the
    fit from the spec's start once ended in a local minimum (chi 3.1, cost 2040, agreement
    0.79 on its own log) and only a restart left it; then re-solving the candidates under the
    re-balanced weight (:func:`sysid._map._final_choice`) moved it out too (cost 1371 before,
    729.8 after). Since friction is fitted per unit mass that minimum is gone: without the
    integral-gain/delay restarts, without any restart, and even from a start at chi 3.1 the
    fit reaches the basin of cost ~730, chi 1.87-1.88, and says nothing of a local minimum.
    On the plant with the Husky's integral action no tuning seed (1-13, 21-30) had one."""
    import sysid._map

    # the plant of seed 23 as it was before husky_like() had integral action, by value: its
    # proportional loops and its lateral stiffness to the last digit
    plant = skid_robot(23).replace(ki_nm_per_rad=0.0, slip_lat_mps=0.06032056538737976)
    log = make_skid_sessions(plant, 1, seed=23, duration_s=90.0, profile="teleop")[0]
    priors = _fixed(husky, driver_track_factor=1.875)
    chi = effective_track_factor(plant, 0.0, 1.0)  # 1.71
    monkeypatch.setattr(sysid._map, "_RESTART_SDS", {})
    fits = [fit_drive([log], geometry=husky.geometry, base_params=husky.drive, priors=priors)]
    monkeypatch.setattr(sysid._map, "_TRACK_RESTARTS_SD", ())
    fits.append(fit_drive([log], geometry=husky.geometry, base_params=husky.drive, priors=priors))
    real = sysid._map.initial_coords

    def at_the_old_minimum(*args, **kwargs):  # type: ignore[no-untyped-def]
        x, notes = real(*args, **kwargs)
        return {**x, "track_factor": math.log(3.1)}, notes

    monkeypatch.setattr(sysid._map, "initial_coords", at_the_old_minimum)
    fits.append(fit_drive([log], geometry=husky.geometry, base_params=husky.drive, priors=priors))
    for r in fits:  # measured 729.8, 729.8, 729.8; chi 1.877, 1.897, 1.865
        assert not any("local minimum" in w for w in r.warnings), r.warnings
        assert chi < r.params.track_factor < 2.0
        assert r.settings["cost"] == pytest.approx(730.2, abs=2.0), r.settings["cost"]
        agree = measure_agreement(log, replay(log, robot=husky, params=r.params, engine="reduced"))
        assert agree.agreement > 0.95  # measured 0.961


def test_the_starts_are_compared_on_the_final_objective(
    husky: RobotSpec, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A 30 s session of seed 22 (a tuning seed). The objective is w_p^2 times the negative
    log posterior, w_p estimated from the residuals: 2.34 at the start point, 0.96-0.98 at
    the best fits. Compared under the start's weight, a track-factor restart won (256.1 vs
    260.7) and its five-step polish under the re-balanced weight ended at cost 246.1, above
    the 234.0 of the fit without the restarts. Every candidate re-solved under the
    re-balanced weight and the lowest kept: 233.3 with the restarts, 233.5 without; more
    starts no longer end higher."""
    import sysid._map

    log = make_skid_sessions(skid_robot(22), 1, seed=22, duration_s=30.0, profile="teleop")[0]
    priors = _fixed(husky, driver_track_factor=1.875)
    both = fit_drive([log], geometry=husky.geometry, base_params=husky.drive, priors=priors)
    monkeypatch.setattr(sysid._map, "_TRACK_RESTARTS_SD", ())
    spec_only = fit_drive([log], geometry=husky.geometry, base_params=husky.drive, priors=priors)
    costs = (both.settings["cost"], spec_only.settings["cost"])
    # one negative-log-posterior unit is w_p^2 ~ 0.95 cost units here
    assert costs[0] <= costs[1] + 0.5 and costs[0] < 236.0, costs  # before: 246.1 vs 234.0
    assert 1.55 < both.params.track_factor < 1.65  # measured 1.595 (plant 1.57)


def test_tiny_changes_of_the_data_keep_the_fit_in_its_basin(husky: RobotSpec) -> None:
    """Seed 101's robot, 30 s sessions, its lateral tyre stiffness x (1, 1 + 1e-7). Before the
    candidates were compared on the final objective the two fits landed in different minima:
    cost 1036.4 and 1083.1, chi 1.92 and 1.90, held-out agreement 0.735 and 0.706 (1 - 1e-7:
    1065.4, 1.93, 0.704). Now 863.2 and 862.5 (about one negative-log-posterior unit, w_p^2 ~
    0.74), chi 1.880 and 1.882, agreement 0.917 and 0.915 (1 - 1e-7: 862.5, 1.879, 0.924).
    The objective is rough on a scale of a few units (the trust region stops on xtol where
    tolerances of 1e-12 find no further descent), so the fit is the best of its candidates,
    not a proven global minimum."""
    base = skid_robot(101)
    cases = [
        (base.replace(slip_lat_mps=base.slip_lat_mps * (1.0 + rel)), 101, 30.0, husky, ("reduced",))
        for rel in (0.0, 1e-7)
    ]
    fitted = map_in_processes(_fit_and_score, cases)
    costs = [cost for _, _, cost in fitted]
    chis = [params.track_factor for _, params, _ in fitted]
    agreements = [agreement for [agreement], _, _ in fitted]
    assert max(costs) - min(costs) < 2.0 and max(costs) < 880.0, costs  # before: 1036, 1083
    assert max(chis) - min(chis) < 0.01, chis
    assert min(agreements) > 0.9 and max(agreements) - min(agreements) < 0.02, agreements
