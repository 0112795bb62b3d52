"""The drive-parameter schema: every field covered, coordinates invert, rules derived from it,
and every shipped spec gives every field a justified prior."""

from __future__ import annotations

import math
import re
from pathlib import Path

import pytest
import yaml
from hypothesis import given
from hypothesis import strategies as st

from robots import list_robots, load_spec
from robots.errors import RobotsValueError, SpecError
from robots.params import (
    COORD_KINDS,
    MAY_BE_INF,
    MAY_BE_NEGATIVE,
    MUST_BE_POSITIVE,
    SCHEMA,
    SIGN_RULES,
    UNITS,
    BaseGeometry,
    DriveParams,
    coords_to_values,
    generic_priors,
)
from robots.spec import SPECS_DIR

GEO = BaseGeometry(
    mass_kg=1.5, yaw_inertia_kgm2=0.015, wheel_radius_m=0.033, wheel_separation_m=0.2
)


def test_schema_covers_every_field_in_order_and_is_documented() -> None:
    assert tuple(SCHEMA) == DriveParams.names()
    for name, f in SCHEMA.items():
        assert f.name == name
        assert f.coord in COORD_KINDS and f.sign in SIGN_RULES and f.axis in ("v", "w", "vw")
        assert f.unit and f.doc and f.lower < f.upper
        assert f.absurd_sd > 0
        assert f.prior_sd(GEO) >= 0 and f.session_sd(GEO) >= 0
        # the field is documented in the DriveParams docstring
        assert name.split("_")[0] in (DriveParams.__doc__ or "")
        # log coordinates need positive values; lin ones must not be inf
        if f.coord == "lin":
            assert not f.may_be_inf
        if f.coord.startswith("log_total"):
            assert f.sign == "total_positive"
        elif f.coord == "log":
            assert f.sign == "positive"


def test_public_rule_sets_are_derived_from_the_schema() -> None:
    assert {"cmd_timeout_s", "wheel_speed_max_radps", "accel_lim_v_mps2"} <= MAY_BE_INF
    assert "delay_s" not in MAY_BE_INF and "motor_gain_nms_per_rad" not in MAY_BE_INF
    assert {"added_mass_kg", "added_yaw_inertia_kgm2"} == MAY_BE_NEGATIVE
    assert "motor_gain_nms_per_rad" in MUST_BE_POSITIVE and "delay_s" not in MUST_BE_POSITIVE
    assert UNITS["viscous_w_nms_per_rad"] == "N m s/rad"


@pytest.mark.parametrize(
    ("name", "value", "words"),
    [
        ("delay_s", -0.1, ">= 0"),
        ("motor_gain_nms_per_rad", 0.0, "> 0"),
        ("delay_s", math.inf, "finite"),
        ("coulomb_w_nm", math.nan, "number"),
    ],
)
def test_validation_follows_the_schema(name: str, value: float, words: str) -> None:
    with pytest.raises(RobotsValueError, match=re.escape(words)):
        DriveParams(**{name: value})


@given(
    name=st.sampled_from(sorted(n for n, f in SCHEMA.items() if not f.choices)),  # not modes
    z=st.floats(-3.0, 3.0),
)
def test_coordinates_invert(name: str, z: float) -> None:
    f = SCHEMA[name]
    lo, hi = f.coord_bounds(GEO)
    zc = min(max(z if f.coord != "lin" else abs(z), lo), hi)
    value = f.from_coord(zc, GEO)
    assert f.to_coord(value, GEO) == pytest.approx(zc, abs=1e-9)
    DriveParams(**{name: value})  # every coordinate in range is a physical value
    if f.coord == "log_total_mass":
        assert GEO.mass_kg + value > 0


def test_total_mass_coordinate_refuses_a_non_positive_total() -> None:
    with pytest.raises(RobotsValueError, match="must be > 0"):
        SCHEMA["added_mass_kg"].to_coord(-2.0, GEO)


def test_generic_priors_cover_every_field() -> None:
    pri = generic_priors(DriveParams(delay_s=0.1), GEO)
    assert set(pri) == set(SCHEMA)
    assert all(p.source == "generic" for p in pri.values())
    assert pri["delay_s"].mean(GEO) == pytest.approx(0.1)
    assert pri["added_mass_kg"].mean(GEO) == pytest.approx(math.log(1.5))
    assert not pri["wheel_speed_max_radps"].informative  # inf nominal: no prior centre


@pytest.mark.parametrize("robot", list_robots())
def test_shipped_specs_give_every_field_a_prior_with_a_justification(robot: str) -> None:
    spec = load_spec(robot)
    assert set(spec.priors) == set(SCHEMA)
    assert all(p.source == "spec" for p in spec.priors.values())
    text = (SPECS_DIR / f"{robot}.yaml").read_text()
    section = text[text.index("\npriors:") :].split("\n")[1:]
    lines = [ln for ln in section if ln.startswith("  ") and not ln.strip().startswith("#")]
    entries = [ln for ln in lines if re.match(r"  \w+: \{", ln)]
    assert len(entries) == len(SCHEMA)
    for i, line in enumerate(section[: section.index(entries[-1]) + 1]):
        if line in entries:  # a comment on the line or on the line(s) just above
            above = section[i - 1].strip() if i else ""
            assert "#" in line or above.startswith("#"), line
    cap = spec.priors["wheel_speed_max_radps"]
    if math.isfinite(spec.drive.wheel_no_load_speed_radps):
        # load and battery derate the top speed through the motors' torque-speed line (its
        # ends vary from session to session with the battery), not through the wheel cap
        assert cap.nominal == spec.drive.wheel_speed_max_radps and cap.session_sd == 0.0
        for name in ("wheel_stall_torque_nm", "wheel_no_load_speed_radps"):
            assert math.isfinite(getattr(spec.drive, name)) and spec.priors[name].informative
            assert spec.priors[name].nominal == getattr(spec.drive, name)
            assert spec.priors[name].session_sd > 0
    else:  # no line: the loaded cap is derated below the no-load datasheet cap
        assert cap.nominal < spec.drive.wheel_speed_max_radps


def test_spec_without_priors_gets_generic_ones_and_bad_priors_are_refused(
    tmp_path: Path,
) -> None:
    doc = yaml.safe_load((SPECS_DIR / "turtlebot3_burger.yaml").read_text())
    del doc["priors"]
    path = tmp_path / "bare.yaml"
    path.write_text(yaml.safe_dump(doc))
    spec = load_spec(path)
    assert all(p.source == "generic" for p in spec.priors.values())
    doc["priors"] = {"delay_s": {"sd": -0.1, "session_sd": 0.0}}
    path.write_text(yaml.safe_dump(doc))
    with pytest.raises(SpecError, match=r"priors\.delay_s\.sd"):
        load_spec(path)
    doc["priors"] = {"delay_sec": {"sd": 0.1, "session_sd": 0.0}}
    path.write_text(yaml.safe_dump(doc))
    with pytest.raises(SpecError, match="delay_sec"):
        load_spec(path)
    doc["priors"] = {"delay_s": {"sd": 0.1}}
    path.write_text(yaml.safe_dump(doc))
    with pytest.raises(SpecError, match="session_sd"):
        load_spec(path)


#: Friction fields: fitted, given priors and sampled per unit of the total mass / yaw inertia.
FRICTION = {
    "coulomb_v_fwd_n": "added_mass_kg",
    "coulomb_v_bwd_n": "added_mass_kg",
    "coulomb_w_nm": "added_yaw_inertia_kgm2",
    "viscous_v_ns_per_m": "added_mass_kg",
    "viscous_w_nms_per_rad": "added_yaw_inertia_kgm2",
}


def test_friction_coordinates_are_per_unit_of_the_total() -> None:
    """A Coulomb force of 0.6 N on a 1.5 kg base plus 0.5 kg of payload is 0.3 N/kg; at the
    spec's own mass (no total given) 0.4 N/kg; the yaw terms are per kg m^2 of yaw inertia."""
    assert {n for n, f in SCHEMA.items() if f.per_field} == set(FRICTION)
    assert {n: SCHEMA[n].per_field for n in FRICTION} == FRICTION
    f = SCHEMA["coulomb_v_fwd_n"]
    assert f.to_coord(0.6, GEO, 2.0) == pytest.approx(0.3)
    assert f.to_coord(0.6, GEO) == pytest.approx(0.4)
    assert f.from_coord(0.3, GEO, 2.0) == pytest.approx(0.6)
    assert SCHEMA["viscous_w_nms_per_rad"].to_coord(0.003, GEO) == pytest.approx(0.2)
    with pytest.raises(RobotsValueError, match="added_mass_kg"):
        f.to_coord(0.6, GEO, 0.0)


@given(
    zf=st.floats(0.0, 5.0),
    z_mass=st.floats(-1.0, 2.0),
    added_inertia=st.floats(-0.005, 0.05),
)
def test_coords_to_values_takes_each_total_from_the_draw_or_the_fixed_values(
    zf: float, z_mass: float, added_inertia: float
) -> None:
    """A friction drawn per kg becomes a force at the drawn mass (the total from the same
    draw), and a yaw friction at the fixed yaw inertia when that does not vary."""
    names = ["coulomb_v_fwd_n", "coulomb_w_nm", "added_mass_kg"]
    values = coords_to_values(
        names, [zf, zf, z_mass], GEO, {"added_yaw_inertia_kgm2": added_inertia}
    )
    mass = GEO.mass_kg + values["added_mass_kg"]
    lo = SCHEMA["added_mass_kg"].coord_bounds(GEO)
    assert mass == pytest.approx(math.exp(min(max(z_mass, lo[0]), lo[1])))
    assert values["coulomb_v_fwd_n"] == pytest.approx(zf * mass)
    assert values["coulomb_w_nm"] == pytest.approx(zf * (GEO.yaw_inertia_kgm2 + added_inertia))


def test_spec_friction_spreads_are_read_in_their_own_unit() -> None:
    """The Kobuki spec writes the Coulomb prior sd as 0.5 N; the prior (coordinate units) is
    that over the spec mass, and the spec written back says 0.5 N again."""
    spec = load_spec("turtlebot2")
    m = spec.geometry.mass_kg
    assert spec.priors["coulomb_v_fwd_n"].sd == pytest.approx(0.5 / m)
    assert spec.priors["coulomb_v_fwd_n"].mean(spec.geometry) == pytest.approx(
        spec.drive.coulomb_v_fwd_n / m
    )
    doc = spec.to_dict()
    assert doc["priors"]["coulomb_v_fwd_n"]["sd"] == pytest.approx(0.5)
