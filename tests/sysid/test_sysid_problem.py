"""The least-squares problem: grouped Jacobian, coordinates, delay recovery as a property."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robots.params import BaseGeometry, DriveParams
from sysid import fit_drive
from sysid._coords import COORDS, Mapper
from sysid._problem import Problem
from sysid.synthetic import step_commands, synthetic_log

GEO = BaseGeometry(
    mass_kg=1.2, yaw_inertia_kgm2=0.012, wheel_radius_m=0.033, wheel_separation_m=0.2
)
BASE = DriveParams(
    delay_s=0.08,
    motor_gain_nms_per_rad=0.008,
    coulomb_v_fwd_n=0.2,
    coulomb_v_bwd_n=0.3,
    coulomb_w_nm=0.01,
    viscous_v_ns_per_m=0.5,
    viscous_w_nms_per_rad=0.01,
    accel_lim_v_mps2=1.5,
    accel_lim_w_radps2=8.0,
    added_mass_kg=0.3,
)


def test_fit_coordinates_are_the_schemas() -> None:
    """One table: the fit's coordinates are the schema's fittable fields, units and axes."""
    from robots.params import SCHEMA

    assert list(COORDS) == [n for n, f in SCHEMA.items() if f.fittable]
    for name, c in COORDS.items():
        f = SCHEMA[name]
        assert (c.unit, c.axis, c.kind, c.step) == (f.unit, f.axis, f.fit_kind, f.fit_step)
        assert c.lower < c.upper
        if c.kind == "log":
            assert (c.lower, c.upper) == f.coord_bounds(GEO)
    assert COORDS["speed_loop_ki_per_s"].kind == "lin"  # a ratio of gains: scale-free
    assert COORDS["added_mass_kg"].kind == "mass"


def test_coordinates_round_trip_every_field() -> None:
    mapper = Mapper(GEO, BASE)
    coords = {f: mapper.to_coord(BASE, f) for f in COORDS if math.isfinite(getattr(BASE, f))}
    back = mapper.from_coords(coords, {})
    for field in coords:
        assert getattr(back, field) == pytest.approx(getattr(BASE, field), rel=1e-12, abs=1e-12)


def test_identifiable_combinations_match_closed_form() -> None:
    ident = Mapper(GEO, BASE).identifiable(BASE)
    k = BASE.motor_gain_nms_per_rad
    kv = 2 * k / GEO.wheel_radius_m**2
    m = GEO.mass_kg + BASE.added_mass_kg
    assert ident["time_constant_v_s"][0] == pytest.approx(m / (kv + 0.5))
    assert ident["gain_v"][0] == pytest.approx(kv / (kv + 0.5))
    assert ident["coulomb_v_bwd_per_mass_mps2"][0] == pytest.approx(0.3 / m)
    assert ident["coulomb_v_fwd_speed_loss_mps"][0] == pytest.approx(0.2 / (kv + 0.5))


def test_grouped_jacobian_equals_dense_when_axes_are_decoupled() -> None:
    t, v, w = step_commands(20.0, seed=4, v_max_mps=0.15, w_max_radps=1.0)
    log = synthetic_log(BASE, GEO, cmd_t_s=t, cmd_v=v, cmd_w=w, seed=4)
    free = [
        "delay_s",
        "added_mass_kg",
        "added_yaw_inertia_kgm2",
        "coulomb_v_fwd_n",
        "coulomb_w_nm",
        "accel_lim_v_mps2",
    ]
    mapper = Mapper(GEO, BASE)
    prob = Problem([log], mapper, free, {}, scale_v=0.02, scale_w=0.1, dt_s=0.005)
    x = np.array([mapper.to_coord(BASE, f) for f in free])
    dense = prob.jacobian(x, coupled=True)
    before = prob.n_evals
    grouped = prob.jacobian(x, coupled=False)
    assert prob.n_evals - before == 4  # delay alone, then 3 (v, w) pairs share simulations
    assert np.allclose(grouped, dense, rtol=1e-9, atol=1e-9)
    assert np.any(dense[prob.rows["v"], 1]) and not np.any(dense[prob.rows["w"], 1])


@settings(max_examples=4, deadline=None, derandomize=True)
@given(delay=st.floats(0.02, 0.35), seed=st.integers(0, 1000))
def test_delay_is_recovered_within_10_ms(delay: float, seed: int) -> None:
    truth = BASE.replace(delay_s=delay)
    t, v, w = step_commands(40.0, seed=seed)
    log = synthetic_log(truth, GEO, cmd_t_s=t, cmd_v=v, cmd_w=w, seed=seed)
    res = fit_drive(
        [log], geometry=GEO, base_params=BASE.replace(delay_s=0.0), odom_v_window_s=0.02
    )
    assert abs(res.params.delay_s - delay) <= 0.010


def test_python_loop_fit_gives_the_same_numbers() -> None:
    t, v, w = step_commands(8.0, seed=12)
    log = synthetic_log(BASE, GEO, cmd_t_s=t, cmd_v=v, cmd_w=w, seed=12, spike_mps=None)
    kw = {"geometry": GEO, "base_params": BASE.replace(delay_s=0.0), "free": ["delay_s"]}
    fast = fit_drive([log], **kw)  # type: ignore[arg-type]
    slow = fit_drive([log], python=True, **kw)  # type: ignore[arg-type]
    assert slow.params.delay_s == pytest.approx(fast.params.delay_s, abs=1e-9)
    assert slow.scores_fit == fast.scores_fit
