"""Bad input and excitation analysis: clear errors, and the parameters a log cannot identify."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robots.params import BaseGeometry, DriveParams
from sysid import (
    ExcitationError,
    LogArrays,
    SysidValueError,
    VelocityLog,
    crop_log,
    fit_drive,
)
from sysid._excitation import analyse, held_command
from sysid._initial import spike_mask
from sysid.synthetic import step_commands, synthetic_log

GEO = BaseGeometry(
    mass_kg=1.0, yaw_inertia_kgm2=0.01, wheel_radius_m=0.033, wheel_separation_m=0.16
)
BASE = DriveParams(delay_s=0.05, motor_gain_nms_per_rad=0.005, wheel_speed_max_radps=8.0)


def _log(
    duration: float = 20.0, v: float = 0.2, w: float = 0.0, *, step_at: float = 2.0
) -> LogArrays:
    t = np.arange(0.0, duration, 0.1)
    cv = np.where(t >= step_at, v, 0.0)
    cw = np.where(t >= step_at, w, 0.0)
    return synthetic_log(BASE, GEO, cmd_t_s=t, cmd_v=cv, cmd_w=cw, seed=1, spike_mps=None)


def test_protocol_is_structural() -> None:
    assert isinstance(_log(), VelocityLog)


def test_too_short_log_is_refused() -> None:
    with pytest.raises(ExcitationError, match=r"too short.*at least 3 s"):
        fit_drive([_log(duration=2.0, step_at=0.5)], geometry=GEO, base_params=BASE)


def test_flat_commands_are_refused() -> None:
    t = np.arange(0.0, 20.0, 0.1)
    log = LogArrays(
        cmd_t_s=t,
        cmd_v=np.full(t.size, 0.2),
        cmd_w=np.zeros(t.size),
        meas_t_s=t,
        meas_v=np.full(t.size, 0.19),
        meas_w=np.zeros(t.size),
        name="flat.mcap",
    )
    with pytest.raises(ExcitationError, match=r"flat\.mcap never change.*cmd_v = 0\.2"):
        fit_drive([log], geometry=GEO, base_params=BASE)


def test_no_motion_is_refused() -> None:
    t = np.arange(0.0, 20.0, 0.1)
    log = LogArrays(
        cmd_t_s=t,
        cmd_v=np.where(t > 5, 0.2, 0.0),
        cmd_w=np.zeros(t.size),
        meas_t_s=t,
        meas_v=np.zeros(t.size),
        meas_w=np.zeros(t.size),
        name="parked.mcap",
    )
    with pytest.raises(ExcitationError, match=r"never moves in parked\.mcap"):
        fit_drive([log], geometry=GEO, base_params=BASE)


@pytest.mark.parametrize("field", ["cmd_v", "meas_t_s", "meas_w"])
def test_nan_is_refused_naming_the_array(field: str) -> None:
    log = _log()
    arr = getattr(log, field).copy()
    arr[5] = np.nan
    bad = LogArrays(**{**log.__dict__, field: arr})
    with pytest.raises(SysidValueError, match=f"'{field}' holds 1 NaN/inf value.*index 5"):
        fit_drive([bad], geometry=GEO, base_params=BASE)


def test_length_mismatch_and_unsorted_times_are_refused() -> None:
    log = _log()
    with pytest.raises(SysidValueError, match="'meas_v' has 3 samples"):
        fit_drive(
            [LogArrays(**{**log.__dict__, "meas_v": np.zeros(3)})], geometry=GEO, base_params=BASE
        )
    with pytest.raises(SysidValueError, match="not sorted"):
        fit_drive(
            [LogArrays(**{**log.__dict__, "cmd_t_s": log.cmd_t_s[::-1].copy()})],
            geometry=GEO,
            base_params=BASE,
        )


def test_bad_free_names_are_refused() -> None:
    with pytest.raises(SysidValueError, match="unknown free parameter 'mass'"):
        fit_drive([_log()], geometry=GEO, base_params=BASE, free=["mass"])
    # the motor gain is fittable now (MAP: its prior resolves the mass/gain family); the
    # command timeout, a firmware setting, is not
    with pytest.raises(SysidValueError, match="cmd_timeout_s' cannot be fitted"):
        fit_drive([_log()], geometry=GEO, base_params=BASE, free=["cmd_timeout_s"])
    with pytest.raises(SysidValueError, match="loss must be one of"):
        fit_drive([_log()], geometry=GEO, base_params=BASE, loss="l3")


@pytest.mark.parametrize(
    ("kw", "words"),
    [
        ({"dt_s": 0.2}, r"dt_s \(--dt\) must be in \(0, 0.05\] s, got 0.2; e.g. --dt 0.005$"),
        ({"dt_s": 0.0}, r"dt_s \(--dt\) .*got 0.0; e.g. --dt 0.005$"),
        ({"bootstrap": -1}, r"bootstrap \(--bootstrap\) .*>= 0 .*got -1; e.g. --bootstrap 20$"),
        ({"bootstrap": 2.5}, r"bootstrap \(--bootstrap\) .*whole number.*got 2.5; e.g."),
        ({"segment_s": 0.5}, r"segment_s must be .*>= 1, got 0.5; e.g. segment_s=10.0$"),
    ],
)
def test_bad_step_and_bootstrap_name_keyword_flag_and_fix(kw: dict[str, float], words: str) -> None:
    with pytest.raises(SysidValueError, match=words) as info:
        fit_drive([_log()], geometry=GEO, base_params=BASE, **kw)  # type: ignore[arg-type]
    assert "\n" not in str(info.value)
    if "bootstrap" in kw:
        assert "segment_s" not in str(info.value)  # the CLI cannot set it


def test_no_reversal_ties_backward_friction_and_says_so() -> None:
    exc = analyse([_log(v=0.2, w=0.0)], GEO, BASE, "auto")
    assert exc.ties == {"coulomb_v_bwd_n": "coulomb_v_fwd_n"}
    assert "coulomb_v_bwd_n" not in exc.free
    assert any(w.startswith("no reversal in the log") for w in exc.warnings)
    # one speed level: viscous trades off with Coulomb
    assert "viscous_v_ns_per_m" not in exc.free
    assert any("one forward speed level (0.20 m/s)" in w for w in exc.warnings)
    # yaw never commanded: the whole yaw axis stays at the prior
    assert "added_yaw_inertia_kgm2" not in exc.free
    assert any("yaw axis is not excited" in w for w in exc.warnings)
    # no wheel near the 8 rad/s cap (0.2 m/s / 0.033 m = 6.1 rad/s)
    assert "wheel_speed_max_radps" not in exc.free
    assert any("no wheel near its speed cap" in w for w in exc.warnings)
    # 0.2 m/s step >= 0.1 m/s: an acceleration limit could show
    assert "accel_lim_v_mps2" in exc.free
    assert not exc.coupled


def test_rich_log_frees_everything_identifiable() -> None:
    t, v, w = step_commands(60.0, seed=2, v_max_mps=0.3)
    log = synthetic_log(BASE, GEO, cmd_t_s=t, cmd_v=v, cmd_w=w, seed=2)
    exc = analyse([log], GEO, BASE, "auto")
    for name in (
        "delay_s",
        "added_mass_kg",
        "added_yaw_inertia_kgm2",
        "coulomb_v_fwd_n",
        "coulomb_v_bwd_n",
        "coulomb_w_nm",
        "viscous_v_ns_per_m",
        "viscous_w_nms_per_rad",
        "accel_lim_v_mps2",
        "accel_lim_w_radps2",
        "wheel_speed_max_radps",
    ):
        assert name in exc.free
    assert exc.coupled  # the wheel cap couples the axes: dense Jacobian


def test_inactive_limit_is_restored_to_prior() -> None:
    res = fit_drive([_log(v=0.2)], geometry=GEO, base_params=BASE)
    est = res.estimate("accel_lim_v_mps2")
    assert est.status == "fixed" and est.value == float("inf")
    assert any("accel_lim_v_mps2 never limited the response" in w for w in res.warnings)


def test_crop_log_keeps_the_held_command() -> None:
    log = _log(duration=20.0, v=0.2, step_at=2.0)
    part = crop_log(log, 10.0, 15.0)
    assert part.meas_t_s.min() >= 10.0 and part.meas_t_s.max() < 15.0
    assert held_command(part.cmd_t_s, part.cmd_v, np.array([10.0]))[0] == 0.2
    with pytest.raises(SysidValueError, match="holds no measurement"):
        crop_log(log, 100.0, 110.0)
    with pytest.raises(SysidValueError, match="empty or not finite"):
        crop_log(log, 5.0, 5.0)


@settings(max_examples=25, deadline=None)
@given(
    t=st.lists(st.floats(0.0, 100.0), min_size=1, max_size=20, unique=True).map(sorted),
    query=st.floats(-10.0, 110.0),
)
def test_held_command_is_the_last_command_at_or_before(t: list[float], query: float) -> None:
    times = np.asarray(t)
    values = np.arange(1.0, times.size + 1.0)
    got = held_command(times, values, np.array([query]))[0]
    before = times <= query
    assert got == (values[before][-1] if before.any() else 0.0)


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 2**31 - 1),
    where=st.integers(10, 189),
    height=st.floats(0.3, 2.0),
)
def test_an_isolated_spike_is_found_and_noise_is_not(seed: int, where: int, height: float) -> None:
    rng = np.random.default_rng(seed)
    x = 0.2 + rng.normal(0.0, 0.005, 200)
    assert not spike_mask(x, 0.05).any()
    x[where] += height
    assert np.flatnonzero(spike_mask(x, 0.05)).tolist() == [where]
