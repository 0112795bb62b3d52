"""The sysid result file: YAML round trip, robots.params reads it, atomic save, clear errors."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import yaml

from robots.errors import ParamsFileError
from robots.params import BaseGeometry, DriveParams, load_drive_params, read_params_file
from sysid import ResultFileError, SysidFileError, SysidResult, fit_drive
from sysid.synthetic import step_commands, synthetic_log

GEO = BaseGeometry(
    mass_kg=1.0, yaw_inertia_kgm2=0.01, wheel_radius_m=0.033, wheel_separation_m=0.16
)
BASE = DriveParams(motor_gain_nms_per_rad=0.005, wheel_speed_max_radps=8.0)
TRUTH = BASE.replace(delay_s=0.1, added_mass_kg=0.3, coulomb_v_fwd_n=0.2, coulomb_v_bwd_n=0.2)


@pytest.fixture(scope="module")
def result() -> SysidResult:
    t, v, w = step_commands(30.0, seed=8)
    log = synthetic_log(TRUTH, GEO, cmd_t_s=t, cmd_v=v, cmd_w=w, seed=8, name="train.mcap")
    val = synthetic_log(TRUTH, GEO, cmd_t_s=t, cmd_v=v, cmd_w=w, seed=9, name="val.mcap")
    return fit_drive(
        [log], geometry=GEO, base_params=BASE, validate=[val], robot="tiny", bootstrap=5, seed=2
    )


def test_yaml_layout(result: SysidResult) -> None:
    doc = yaml.safe_load(result.to_yaml())
    assert doc["format"] == "sim2real.sysid/1"
    assert doc["robot"] == "tiny"
    assert set(doc["parameters"]) == set(DriveParams.names())
    delay = doc["parameters"]["delay_s"]
    assert delay["status"] == "fitted" and delay["unit"] == "s"
    assert delay["ci95"][0] < delay["value"] < delay["ci95"][1]
    # MAP: the motor gain is fitted against its (generic) prior, which the data narrow
    gain = doc["parameters"]["motor_gain_nms_per_rad"]
    assert gain["status"] == "fitted" and gain["unit"] == "N m s/rad" and gain["coord"] == "log"
    assert gain["prior_sd"] == 1.0 and 0 < gain["sd_ratio"] < 1.0
    assert doc["parameters"]["cmd_timeout_s"] == {
        "value": math.inf,
        "std": None,
        "ci95": None,
        "unit": "s",
        "status": "fixed",
        "coord": "log",
        "coord_std": None,
        "prior_sd": None,
        "sd_ratio": None,
    }
    assert doc["randomization"]["format"] == "sim2real.randomization/2"
    assert "delay_s" in doc["randomization"]["names"]
    assert set(doc["priors"]) == set(DriveParams.names())
    assert "time_constant_v_s" in doc["identifiable"]
    assert [d["role"] for d in doc["data"]] == ["fit", "validation"]
    assert doc["data"][0]["file"] == "train.mcap"
    assert doc["scores"]["validation"][0]["log"] == "val.mcap"
    assert set(doc["linear"]["v"]) >= {"rise_time_s", "settling_time_s", "bandwidth_radps"}
    assert isinstance(doc["warnings"], list) and doc["tool_version"]


def test_save_load_round_trip(result: SysidResult, tmp_path: Path) -> None:
    path = result.save(tmp_path / "params.yaml")
    back = SysidResult.load(path)
    assert back.params == result.params
    assert back.estimates == result.estimates
    assert back.scores_fit == result.scores_fit
    assert back.warnings == result.warnings
    assert back.correlation_names == result.correlation_names
    assert back.bootstrap_std == pytest.approx(result.bootstrap_std)
    assert set(result.bootstrap_std) == set(result.correlation_names)
    assert list(tmp_path.iterdir()) == [path]  # no temp file left


def test_robots_reads_the_result_file(result: SysidResult, tmp_path: Path) -> None:
    path = result.save(tmp_path / "params.yaml")
    pf = read_params_file(path)
    assert pf.robot == "tiny"
    assert pf.values["delay_s"] == pytest.approx(result.params.delay_s)
    assert "delay_s" in pf.stds and "cmd_timeout_s" not in pf.stds
    params = load_drive_params(path, robot="tiny", base=DriveParams())
    assert params == result.params
    with pytest.raises(ParamsFileError, match="identified for robot 'tiny'"):
        load_drive_params(path, robot="turtlebot2", base=DriveParams())


def test_save_into_missing_folder_leaves_nothing(result: SysidResult, tmp_path: Path) -> None:
    target = tmp_path / "missing" / "params.yaml"
    with pytest.raises(SysidFileError, match=r"folder .*missing.* does not exist"):
        result.save(target)
    assert not (tmp_path / "missing").exists()


def test_load_errors(tmp_path: Path) -> None:
    with pytest.raises(ResultFileError, match="does not exist"):
        SysidResult.load(tmp_path / "nope.yaml")
    other = tmp_path / "other.yaml"
    other.write_text("format: something/2\n")
    with pytest.raises(ResultFileError, match="'format' is 'something/2'"):
        SysidResult.load(other)
    broken = tmp_path / "broken.yaml"
    broken.write_text("format: sim2real.sysid/1\nrobot: x\n")
    with pytest.raises(ResultFileError, match="malformed"):
        SysidResult.load(broken)


def test_bootstrap_is_seeded() -> None:
    t, v, w = step_commands(30.0, seed=8)
    log = synthetic_log(TRUTH, GEO, cmd_t_s=t, cmd_v=v, cmd_w=w, seed=8)
    kw = {"geometry": GEO, "base_params": BASE, "free": ["delay_s", "added_mass_kg"]}
    a = fit_drive([log], bootstrap=4, seed=5, **kw)  # type: ignore[arg-type]
    b = fit_drive([log], bootstrap=4, seed=5, **kw)  # type: ignore[arg-type]
    c = fit_drive([log], bootstrap=4, seed=6, **kw)  # type: ignore[arg-type]
    assert a.bootstrap_std == b.bootstrap_std
    assert a.bootstrap_std != c.bootstrap_std
