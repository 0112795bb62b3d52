"""``robots new`` specs and ``robots check``: geometry rules and the 1 s pybullet drive test.

The wrong-body spec (body reaching into the ground) drove the robot *backwards* on a forward
command in pybullet; it is built here from a ``robots new`` spec and must be refused both by
the geometry check and by the drive test, and by PybulletRobot itself.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
import yaml

from robots.check import _drive_items, check_spec, ensure_spec_ok
from robots.errors import RobotsValueError, SpecError, UnknownRobotError
from robots.params import SCHEMA
from robots.spec import list_robots, load_spec
from robots.template import NewRobot, spec_text


def _write(tmp_path: Path, text: str, name: str = "r.yaml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def _wrong_body(text: str, z_m: float = -0.03) -> str:
    return re.sub(
        r"xyz_m: \[0\.0, 0\.0, [-0-9.e]+\]\}", f"xyz_m: [0.0, 0.0, {z_m}]}}", text, count=1
    )


@pytest.fixture(scope="module")
def neato_text() -> str:
    return spec_text("neato", wheel_separation_m=0.248, max_speed_mps=0.3)


def test_new_spec_is_complete_and_documented(neato_text: str, tmp_path: Path) -> None:
    spec = load_spec(_write(tmp_path, neato_text))
    doc = yaml.safe_load(neato_text)
    # every drive field has a written prior; given numbers are narrow, guessed ones wide
    assert set(doc["priors"]) == set(SCHEMA)
    assert all(p.source == "spec" for p in spec.priors.values())
    assert spec.priors["wheel_speed_max_radps"].sd == 0.15  # --max-speed was given
    assert spec.priors["speed_lim_w_radps"].sd == 0.7  # --max-turn-rate was not
    assert spec.priors["added_mass_kg"].sd == 0.7  # --mass was not
    # the top speed is a wheel cap scaling both wheels (no separate v clamp)
    assert spec.drive.speed_lim_v_mps == math.inf and spec.max_v_mps == 0.3
    assert spec.geometry.wheel_separation_m == 0.248
    assert math.isclose(spec.max_w_radps, 2 * 0.3 / 0.248, rel_tol=1e-5)
    assert math.isclose(
        spec.drive.wheel_speed_max_radps * spec.geometry.wheel_radius_m, 0.3, rel_tol=1e-5
    )
    # every line that sets a geometry number says where it came from
    for key in ("radius_m: 0.0496", "mass_kg: 3.58", "max_w_radps"):
        line = next(ln for ln in neato_text.splitlines() if key in ln)
        assert "prior:" in line or "given" in line, line


def test_given_numbers_are_used(tmp_path: Path) -> None:
    text = spec_text(
        "husky",
        wheel_separation_m=0.555,
        wheel_radius_m=0.165,
        mass_kg=50.0,
        max_speed_mps=1.0,
        max_turn_rate_radps=2.0,
        footprint_radius_m=0.5,
    )
    spec = load_spec(_write(tmp_path, text))
    assert spec.geometry.wheel_radius_m == 0.165 and spec.max_w_radps == 2.0
    assert math.isclose(spec.rigid_mass_kg, 50.0, rel_tol=1e-5)
    assert spec.body.size_m[0] == 1.0 and spec.priors["added_mass_kg"].sd == 0.3
    assert check_spec(spec, drive_test=False).passed


@pytest.mark.parametrize(
    ("drive", "given", "expected"),
    [("diff", None, 1.0), ("skid", None, 1.6), ("diff", 1.875, 1.875)],
)
def test_driver_track_factor_is_the_drivers_multiplier(
    drive: str, given: float | None, expected: float, tmp_path: Path
) -> None:
    """A diff spec of a Husky states its driver's wheel_separation_multiplier (1.875) with the
    geometric track (track_factor 1): the model then turns the wheels as the driver does."""
    text = spec_text("b", wheel_separation_m=0.555, drive=drive, driver_track_factor=given)
    spec = load_spec(_write(tmp_path, text))
    assert spec.drive.driver_track_factor == expected
    assert spec.drive.track_factor == (1.0 if drive == "diff" else 1.6)
    line = next(ln for ln in text.splitlines() if ln.strip().startswith("driver_track_factor:"))
    assert ("given" in line) is (given is not None), line
    assert check_spec(spec, drive_test=False).passed


@pytest.mark.parametrize("given", [None, 1.0, 2.2])
def test_track_factor_given_centres_a_narrow_prior(given: float | None, tmp_path: Path) -> None:
    """A skid steer whose recordings read the yaw rate from its encoders sees the geometric
    track (``--track-factor 1``): the prior is centred there, narrow as a given number's."""
    text = spec_text("b", wheel_separation_m=1.08, drive="skid", track_factor=given)
    spec = load_spec(_write(tmp_path, text))
    prior = spec.priors["track_factor"]
    assert spec.drive.track_factor == prior.nominal == (given or 1.6)
    assert prior.sd == (0.3 if given is None else 0.1)
    line = next(ln for ln in text.splitlines() if ln.strip().startswith("track_factor: "))
    assert ("given" in line) is (given is not None), line


@pytest.mark.parametrize(
    ("kw", "match"),
    [
        ({"wheel_separation_m": -0.2}, "wheel_separation_m must be a finite number > 0"),
        ({"wheel_separation_m": 0.2, "mass_kg": math.nan}, "mass_kg must be"),
        ({"wheel_separation_m": 0.3, "footprint_radius_m": 0.1}, "wheels would stick out"),
        ({"wheel_separation_m": 0.3, "drive": "tank"}, "drive must be one of"),
        ({"wheel_separation_m": 0.3, "driver_track_factor": 0.1}, "must be in \\[0.5, 5\\]"),
        ({"wheel_separation_m": 0.3, "driver_track_factor": math.inf}, "driver_track_factor"),
        ({"wheel_separation_m": 0.3, "track_factor": 1.2}, "on drive 'diff'"),
        ({"wheel_separation_m": 0.3, "drive": "skid", "track_factor": 0.8}, "in \\[1, 4\\]"),
        ({"wheel_separation_m": 0.3, "wheel_cap": "each"}, "wheel_cap must be one of"),
    ],
)
def test_new_refuses_bad_numbers(kw: dict, match: str) -> None:
    with pytest.raises(RobotsValueError, match=match):
        NewRobot.from_facts("x", **kw)


@pytest.mark.parametrize("name", list_robots())
def test_shipped_specs_pass(name: str) -> None:
    report = check_spec(load_spec(name))
    assert report.passed, report.reason()
    forward = next(i for i in report.items if i.name == "forward drive")
    assert "-" in forward.detail or "+" in forward.detail


@pytest.mark.parametrize("b", [0.12, 0.248, 0.4, 0.6])
def test_new_specs_pass_the_drive_test(b: float, tmp_path: Path) -> None:
    report = check_spec(load_spec(_write(tmp_path, spec_text("r", wheel_separation_m=b))))
    assert report.passed, report.reason()


def test_wrong_body_spec_is_refused(neato_text: str, tmp_path: Path) -> None:
    path = _write(tmp_path, _wrong_body(neato_text), "wrong_body.yaml")
    spec = load_spec(path)  # the loader accepts it: the numbers are all valid on their own
    report = check_spec(spec)
    assert not report.passed
    assert report.items[0].name == "body clear of the ground" and not report.items[0].passed
    assert "0.0151 m below the ground" in report.reason() and str(path) in report.reason()
    # the physics agrees: the wheels hardly touch, so the base barely moves and turns wrongly
    drive = {i.name: i for i in _drive_items(spec)}
    assert not drive["forward drive"].passed
    shortfall = re.search(r"\(([-+]\d+)% of the kinematic speed", drive["forward drive"].detail)
    assert shortfall is not None and int(shortfall.group(1)) <= -50, drive["forward drive"].detail
    assert not drive["turn"].passed
    assert not drive["wheels touch the ground"].passed
    from robots.pybullet_robot import PybulletRobot

    with pytest.raises(SpecError, match="fails the check 'body clear of the ground'"):
        PybulletRobot(spec)


def test_com_outside_support_polygon(neato_text: str, tmp_path: Path) -> None:
    doc = yaml.safe_load(neato_text)
    doc["casters"] = doc["casters"][:1]  # front skid only: the base tips backwards
    doc["point_masses"] = [{"name": "battery", "mass_kg": 2.0, "xyz_m": [-0.12, 0.0, 0.0]}]
    spec = load_spec(_write(tmp_path, yaml.safe_dump(doc)))
    item = next(i for i in check_spec(spec, drive_test=False).items if "centre of mass" in i.name)
    assert not item.passed and "outside the support polygon" in item.detail
    doc["casters"] = []
    item = next(
        i
        for i in check_spec(
            load_spec(_write(tmp_path, yaml.safe_dump(doc))), drive_test=False
        ).items
        if "centre of mass" in i.name
    )
    assert not item.passed and "only the wheel axle" in item.detail


def test_ensure_is_cached_per_spec(neato_text: str, tmp_path: Path) -> None:
    spec = load_spec(_write(tmp_path, neato_text))
    ensure_spec_ok(spec)
    from robots import check

    n = len(check._CHECKED)
    ensure_spec_ok(spec)
    assert len(check._CHECKED) == n


def test_did_you_mean_robot() -> None:
    with pytest.raises(UnknownRobotError, match="did you mean 'turtlebot3_burger'"):
        load_spec("turtlebot3_buger")
    with pytest.raises(UnknownRobotError) as info:
        load_spec("zzzz")
    assert "did you mean" not in str(info.value)


def test_did_you_mean_a_spec_file(
    neato_text: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    _write(tmp_path, neato_text, "neato.yaml")
    with pytest.raises(UnknownRobotError, match=r"did you mean '.*neato\.yaml'\?"):
        load_spec(tmp_path / "neato.yml")  # mistyped suffix
    with pytest.raises(UnknownRobotError, match=r"did you mean '.*neato\.yaml'\?"):
        load_spec(tmp_path / "naeto.yaml")  # mistyped name
    with pytest.raises(UnknownRobotError) as info:
        load_spec(tmp_path / "husky.yaml")
    assert "did you mean" not in str(info.value)
    monkeypatch.chdir(tmp_path)  # `robots new neato` wrote neato.yaml; `--robot neato` names it
    with pytest.raises(UnknownRobotError, match=r"did you mean the file 'neato\.yaml'\?"):
        load_spec("neato")


def test_a_heavy_bases_torque_stays_inside_the_schema_range(tmp_path: Path) -> None:
    """A 1.08 m skid steer (~200 kg from the template) gets a traction prior above 100 N m;
    that prior and a fitted torque cap of several hundred N m stay what they are in draws
    and at the mean (a range ending at 100 N m stalled every member of such a band)."""
    from robots.randomization import DriveDistribution

    spec = load_spec(_write(tmp_path, spec_text("b", wheel_separation_m=1.08, wheel_radius_m=0.3,
                                                drive="skid")))  # fmt: skip
    field = SCHEMA["wheel_torque_max_nm"]
    assert spec.drive.wheel_torque_max_nm > 100.0
    assert math.exp(field.coord_bounds(spec.geometry)[1]) > spec.drive.wheel_torque_max_nm
    dist = DriveDistribution(
        robot="b", geometry=spec.geometry, names=("wheel_torque_max_nm",),
        mean=(math.log(750.0),), covariance=((0.25,),),
        fixed={n: getattr(spec.drive, n) for n in SCHEMA if n != "wheel_torque_max_nm"},
    )  # fmt: skip
    assert math.isclose(dist.mean_params().wheel_torque_max_nm, 750.0, rel_tol=1e-9)
    drawn = [p.wheel_torque_max_nm for p in dist.sample(np.random.default_rng(0), 200)]
    assert max(drawn) > 1500.0 and len(set(drawn)) == 200
