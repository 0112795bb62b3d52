"""The noise ceiling and the noise-only band assume the checked log's own odometry noise."""

from __future__ import annotations

import json
import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from _agreement_fixtures import HIDDEN, ROBOT, write_log, write_params
from hypothesis import given
from hypothesis import settings as settings_
from hypothesis import strategies as st

from robots.randomization import ObservationNoise
from sim2real.agreement.latency import (
    band_log_noise,
    band_noise,
    log_noise,
    noise_ceiling,
    noise_note,
)
from sim2real.cli import main
from sim2real.logs import Trace, read_trace
from sysid.hfnoise import RESPONSE_METHOD
from sysid.steady import MIN_STEADY_SAMPLES, SteadyNoise


@pytest.mark.parametrize(("noise_v", "noise_w"), [(0.003, 0.02), (0.012, 0.06), (0.0, 0.0)])
def test_log_noise_recovers_the_white_noise_of_a_log(
    tmp_path: Path, noise_v: float, noise_w: float
) -> None:
    """Golden: steps held 2 s, 30 Hz odometry with known Gaussian noise; within 15 %."""
    own = log_noise(read_trace(write_log(tmp_path / "l.mcap", noise_v=noise_v, noise_w=noise_w)))
    assert own.measured and own.n_samples > 300
    assert own.std_v_mps == pytest.approx(noise_v, rel=0.15, abs=1e-6)
    assert own.std_w_radps == pytest.approx(noise_w, rel=0.15, abs=1e-6)


def test_a_log_of_ever_changing_commands_keeps_the_fits_noise() -> None:
    t = np.arange(0, 20_000_000_000, 50_000_000)  # 20 s at 20 Hz
    cmd = 0.1 + 0.05 * np.sin(np.arange(t.size))  # a controller: a new command every message
    trace = Trace(cmd_t_ns=t, cmd_v=cmd, cmd_w=0 * cmd, meas_t_ns=t, meas_v=cmd, meas_w=0 * cmd)
    own = log_noise(trace)
    assert not own.measured and own.n_samples < MIN_STEADY_SAMPLES
    assert math.isnan(own.std_v_mps)
    fit = ObservationNoise(std_v_mps=0.01, std_w_radps=0.05)
    note = noise_note(own, fit)
    assert "30 needed" in note and "use the fit's: v 0.01 m/s and w 0.05 rad/s" in note
    assert noise_note(own, None) == ""


def test_agree_judges_by_the_checked_logs_noise_not_the_fits(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A noisier unit than the fit's (4x in v, 3x in w): the ceiling and the noise-only band
    are that log's, the note says both, and the terminal's verdict says it too."""
    log = write_log(tmp_path / "noisy.mcap", noise_v=0.012, noise_w=0.06)
    params = write_params(tmp_path / "params.yaml", HIDDEN)  # its noise: 0.003 m/s, 0.02 rad/s
    out = tmp_path / "agree.json"
    args = ["agree", str(log), "--robot", ROBOT, "--params", str(params), "--engine", "reduced"]
    assert main([*args, "--json", str(out)]) == 0
    figures = json.loads(out.read_text())
    own = log_noise(read_trace(log))
    expected = noise_ceiling(
        ObservationNoise(std_v_mps=own.std_v_mps, std_w_radps=own.std_w_radps),
        tol_v=0.02,
        tol_w=0.1,
    )
    assert figures["noise_std_v_mps"] == pytest.approx(0.012, rel=0.15)
    # the log's own noise law at each sample's speed (sysid.steady.speed_noise): on white
    # noise of one sd its estimate stays within 0.015 of the constant's (the fit's: ~1.0)
    assert figures["noise_ceiling"] == pytest.approx(expected.agreement, abs=0.015)
    assert figures["noise_band_width_w_radps"] == pytest.approx(expected.band_width_w_radps)
    assert figures["noise_band_width_v_mps"] > 3 * 3.29 * 0.003  # not the fit's 0.003 m/s
    note = figures["notes"][-1]
    assert note.startswith("the noise ceiling and the noise-only band use this log's own")
    assert "the fit estimated v 0.003 m/s and w 0.02 rad/s" in note
    assert note in capsys.readouterr().out  # the verdict's reasons in the terminal


@pytest.mark.realdata
def test_real_neato_logs_measure_their_own_noise_or_say_why_not(realdata_dir: Path) -> None:
    """A 2018 Neato square (pose-derived velocity, commands held on each side) measures its
    own noise; a log whose commands never stay for over a second cannot."""
    square = log_noise(read_trace(realdata_dir / "neato_yycho0108_drive_square_demo.mcap"))
    assert square.measured and square.n_samples >= 150
    assert 0.0 < square.std_v_mps < 0.005 and 0.0 < square.std_w_radps < 0.02
    bag = read_trace(realdata_dir / "neato_ksoltan_bag-file-name_2018-09-15-10-16-08.mcap")
    assert not log_noise(bag).measured


_FILE = ObservationNoise(std_v_mps=0.016, std_w_radps=0.02)
_FITTED = {"measurement_noise": {"std_v_mps": 0.012, "std_w_radps": 0.015, "samples": 87}}


@pytest.mark.parametrize(
    ("settings", "own"),
    [
        ({}, SteadyNoise(std_v_mps=0.001, std_w_radps=0.03, n_samples=200)),  # no fit-log noise
        (_FITTED, SteadyNoise(std_v_mps=math.nan, std_w_radps=math.nan, n_samples=5)),  # unmeasured
        (None, SteadyNoise(std_v_mps=0.001, std_w_radps=0.03, n_samples=200)),
    ],
)
def test_the_band_keeps_the_files_noise_when_a_source_cannot_be_told(
    settings: object, own: SteadyNoise
) -> None:
    assert band_noise(_FILE, settings, own) == (_FILE, "")


@settings_(max_examples=200, deadline=None)
@given(own_v=st.floats(0.0, 0.05), own_w=st.floats(0.0, 0.2))
def test_the_band_noise_is_the_models_share_plus_the_logs_own(own_v: float, own_w: float) -> None:
    own = SteadyNoise(std_v_mps=own_v, std_w_radps=own_w, n_samples=100)
    noise, note = band_noise(_FILE, _FITTED, own)
    assert "this log's own measurement noise" in note
    model_v, model_w = math.sqrt(0.016**2 - 0.012**2), math.sqrt(0.02**2 - 0.015**2)
    assert noise.std_v_mps == pytest.approx(math.hypot(model_v, own_v), rel=1e-9)
    assert noise.std_w_radps == pytest.approx(math.hypot(model_w, own_w), rel=1e-9)
    # never below the log's own noise nor the model's share; the fit logs' own source: the file's
    assert noise.std_v_mps >= max(own_v, model_v) - 1e-12
    same = SteadyNoise(std_v_mps=0.012, std_w_radps=0.015, n_samples=100)
    assert band_noise(_FILE, _FITTED, same)[0].std_v_mps == pytest.approx(0.016)


def test_a_log_that_never_holds_a_command_is_measured_by_what_the_model_leaves() -> None:
    """A controller's new command every message (20 Hz, a 0.3 s lag, 0.01 m/s and 0.05 rad/s of
    noise): no held command, so only a replay measures it (what the replay does not explain,
    as agree's band and a calibration's model share read it); without one, the file's."""
    rng = np.random.default_rng(0)
    t = np.arange(0, 60_000_000_000, 50_000_000)  # 60 s at 20 Hz
    s = t / 1e9
    cmd = 0.2 + 0.1 * np.sin(0.3 * s)
    trace = Trace(cmd_t_ns=t, cmd_v=cmd, cmd_w=0 * cmd + 0.3, meas_t_ns=t,
                  meas_v=0.2 + 0.1 * np.sin(0.3 * (s - 0.3)) + rng.normal(0, 0.01, t.size),
                  meas_w=0.3 + rng.normal(0, 0.05, t.size))  # fmt: skip
    assert not log_noise(trace).measured
    assert band_noise(_FILE, _FITTED, band_log_noise(trace)) == (_FILE, "")
    model = SimpleNamespace(v=0.2 + 0.1 * np.sin(0.3 * (s - 0.25)), w=0 * s + 0.3)  # misses
    own = band_log_noise(trace, replayed=model)
    assert own.measured and own.method == RESPONSE_METHOD
    assert own.std_v_mps == pytest.approx(0.01, rel=0.2)
    assert own.std_w_radps == pytest.approx(0.05, rel=0.2)
    short = Trace(cmd_t_ns=t[:25], cmd_v=cmd[:25], cmd_w=0 * cmd[:25], meas_t_ns=t[:25],
                  meas_v=cmd[:25], meas_w=0 * cmd[:25])  # fmt: skip
    cut = SimpleNamespace(v=cmd[:25], w=0 * cmd[:25])
    assert not band_log_noise(short, replayed=cut).measured  # too few readings: unmeasured


@settings_(max_examples=100, deadline=None)
@given(
    model_v=st.floats(0.0, 0.05), model_w=st.floats(0.0, 0.2), own_v=st.floats(0.0, 0.05),
    file_v=st.floats(0.0, 0.05),
)  # fmt: skip
def test_a_held_out_model_share_replaces_the_in_sample_one(
    model_v: float, model_w: float, own_v: float, file_v: float
) -> None:
    """With the calibration's held-out share the file's (in-sample) noise no longer enters:
    whatever the fit's residual sd, the band is that share beside the log's own noise."""
    held = {"model_noise_std_v_mps": model_v, "model_noise_std_w_radps": model_w}
    own = SteadyNoise(std_v_mps=own_v, std_w_radps=0.01, n_samples=100)
    file = ObservationNoise(std_v_mps=file_v, std_w_radps=0.02)
    noise, note = band_noise(file, _FITTED, own, calibration=held)
    assert noise.std_v_mps == pytest.approx(math.hypot(model_v, own_v), abs=1e-12)
    assert noise.std_w_radps == pytest.approx(math.hypot(model_w, 0.01), abs=1e-12)
    assert "measured on the calibration logs the fit never saw" in note
    # a calibration without the record (older file, unmeasured logs: null) keeps the fit rule
    for block in ({}, {"model_noise_std_v_mps": None, "model_noise_std_w_radps": None}):
        assert band_noise(file, _FITTED, own, calibration=block) == band_noise(file, _FITTED, own)


def test_the_bands_v_noise_is_read_where_v_is_commanded() -> None:
    """Commands held 4 s, one straight (0.2 m/s, v noise 0.01 m/s) to three spins in place (v
    reads 5e-4 m/s of noise): pooled, the spins set the log's v noise; the band's is the
    straights' own, its w the pooled one."""
    rng = np.random.default_rng(1)
    t = np.arange(0, 160_000_000_000, 50_000_000)
    straight = (np.floor(t / 4e9) % 4) == 0
    cmd_v, cmd_w = np.where(straight, 0.2, 0.0), np.where(straight, 0.0, 1.0)
    trace = Trace(cmd_t_ns=t, cmd_v=cmd_v, cmd_w=cmd_w, meas_t_ns=t,
                  meas_v=cmd_v + rng.normal(0.0, np.where(straight, 0.01, 5e-4)),
                  meas_w=cmd_w + rng.normal(0.0, 0.03, t.size))  # fmt: skip
    pooled, band = log_noise(trace), band_log_noise(trace)
    assert pooled.std_v_mps < 0.2 * 0.01
    assert band.std_v_mps == pytest.approx(0.01, rel=0.15)
    assert band.std_w_radps == pooled.std_w_radps and band.n_samples == pooled.n_samples
