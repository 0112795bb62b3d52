"""The envelope a fit saw (sysid.envelope): measured, written, read, checked."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from sysid import LogArrays, SysidResult
from sysid.envelope import Envelope, check_envelope, envelope_of, unknown_envelope


def _log(v: float, w: float, seconds: float = 20.0, noise: float = 0.0, seed: int = 0) -> LogArrays:
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, seconds, 0.05)
    on = t >= 2.0
    return LogArrays(
        cmd_t_s=t,
        cmd_v=np.where(on, v, 0.0),
        cmd_w=np.where(on, w, 0.0),
        meas_t_s=t,
        meas_v=np.where(on, v, 0.0) + rng.normal(0, noise, t.size),
        meas_w=np.where(on, w, 0.0) + rng.normal(0, 10 * noise, t.size),
    )


def test_a_spin_in_place_fit_does_not_cover_arcs() -> None:
    spin = envelope_of([_log(0.0, 1.0)])
    assert spin.v_mps == 0.0 and spin.vw == 0.0 and spin.w_radps == pytest.approx(1.0)
    check = check_envelope(spin, _log(0.25, 0.5))
    assert check.known and check.share_outside == pytest.approx(1.0)
    by = {e.quantity: e for e in check.excesses}
    assert set(by) >= {"v_mps", "vw"} and "w_radps" not in by
    assert by["v_mps"].checked == pytest.approx(0.25) and by["v_mps"].fitted == 0.0
    assert "speed_lim_v_mps" in check.uncertain and "track_factor" in check.uncertain
    assert "|v w| (turning while driving) up to 0.125 m rad/s^2 where the fit saw 0" in (
        check.sentence
    )


def test_noise_of_the_same_driving_stays_inside() -> None:
    fit = envelope_of([_log(0.3, 0.6, noise=0.005, seed=1)])
    check = check_envelope(fit, _log(0.3, 0.6, noise=0.005, seed=2))
    assert check.share_outside < 0.01 and check.sentence == ""


def test_faster_driving_is_measured_by_how_much_and_how_long() -> None:
    fit = envelope_of([_log(0.2, 0.0)])
    t = np.arange(0.0, 20.0, 0.05)
    v = np.where(t < 15.0, 0.2, 0.7)  # the last quarter at 3.5x the speed
    log = LogArrays(cmd_t_s=t, cmd_v=v, cmd_w=np.zeros(t.size), meas_t_s=t, meas_v=v,
                    meas_w=np.zeros(t.size))  # fmt: skip
    check = check_envelope(fit, log)
    v_excess = next(e for e in check.excesses if e.quantity == "v_mps")
    assert v_excess.share == pytest.approx(0.25, abs=0.01)
    assert v_excess.checked == pytest.approx(0.7)
    assert any(e.quantity == "dv_mps2" for e in check.excesses)  # a 0.5 m/s step, fit 0.2


def test_the_envelope_round_trips_through_a_params_file(tmp_path: Path) -> None:
    env = Envelope(v_mps=0.31234567, w_radps=1.0, vw=0.1, dv_mps2=0.5, dw_radps2=3.0)
    assert Envelope.from_dict(env.to_dict()) == Envelope(
        v_mps=0.3123, w_radps=1.0, vw=0.1, dv_mps2=0.5, dw_radps2=3.0
    )
    assert Envelope.from_dict({}) is None and Envelope.from_dict({"v_mps": "x"}) is None
    unknown = unknown_envelope("old.yaml")
    assert not unknown.known and math.isnan(unknown.share_outside)
    assert "old.yaml" in unknown.sentence and "unknown" in unknown.sentence


@pytest.mark.slow
def test_sysid_fit_writes_the_envelope(tmp_path: Path) -> None:
    from sim2real.cli import main

    repo = Path(__file__).resolve().parents[2]
    out = tmp_path / "p.yaml"
    log = repo / "data" / "demo_train.mcap"
    assert main(["sysid", "fit", str(log), "--robot", "turtlebot3_burger", "-o", str(out)]) == 0
    block = yaml.safe_load(out.read_text())["envelope"]
    assert set(block) == {"v_mps", "w_radps", "vw", "dv_mps2", "dw_radps2"}
    assert 0.1 < block["v_mps"] < 0.3 and block["vw"] > 0
    assert SysidResult.load(out).envelope == Envelope.from_dict(block)


def test_the_sentence_names_every_quantity_with_its_share_and_parameters() -> None:
    """Gentle straight driving fitted; a checked log that goes 4x as fast half-way while
    turning at 1.5 rad/s: |v|, |w|, |v w| and both accelerations are outside, each with its
    largest value, the fit's, the share of the samples and the parameters left uncertain."""
    fit = envelope_of([_log(0.1, 0.0)])
    t = np.arange(0.0, 20.0, 0.05)
    v = np.where(t < 2.0, 0.0, np.where(t < 11.0, 0.1, 0.4))
    w = np.where(t < 11.0, 0.0, 1.5)
    log = LogArrays(cmd_t_s=t, cmd_v=v, cmd_w=w, meas_t_s=t, meas_v=v, meas_w=w)
    check = check_envelope(fit, log)
    by = {e.quantity: e for e in check.excesses}
    assert set(by) == {"v_mps", "w_radps", "vw", "dv_mps2", "dw_radps2"}
    assert by["v_mps"].share == pytest.approx(0.5, abs=0.01)  # 9 s of 18 s active
    assert by["w_radps"].share == pytest.approx(0.5, abs=0.01)
    assert by["vw"].checked == pytest.approx(0.6)
    assert 0 < by["dw_radps2"].share < 0.03  # the step only, over the 0.2 s window
    for label in ("|v| up to 0.4 m/s where the fit saw 0.1 (", "|w| up to 1.5 rad/s",
                  "|v w| (turning while driving) up to 0.6", "|dv/dt| up to", "|dw/dt| up to"):  # fmt: skip
        assert label in check.sentence
    assert check.sentence.count("% of the samples)") == 5
    assert check.sentence.startswith("this log leaves the envelope the fit saw for 50.")
    for p in ("speed_lim_w_radps", "accel_lim_v_mps2", "accel_lim_w_radps2", "track_factor"):
        assert p in check.uncertain and p in check.sentence
