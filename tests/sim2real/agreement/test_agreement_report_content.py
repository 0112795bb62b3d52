"""Report building blocks: step segments, rolling agreement, parameter rows, the HTML page."""

from __future__ import annotations

import base64
import math
import re
from pathlib import Path

import numpy as np
import pytest
import yaml
from _agreement_fixtures import ROBOT, hidden_params, spec, write_log
from hypothesis import given
from hypothesis import strategies as st

from robots.params import DriveParams
from sim2real.agreement.figures import measure_agreement
from sim2real.agreement.replay import replay
from sim2real.agreement.report import ReportInput, ReportRun, param_rows, write_report
from sim2real.agreement.report._plots import (
    MIN_BAND_SHARE,
    Band,
    band_legend,
    rolling_agreement,
    visible_band,
)
from sim2real.agreement.report._steps import Step, find_steps, step_response
from sim2real.errors import Sim2RealValueError
from sim2real.logs import read_trace


def test_find_steps_keeps_held_changes_only() -> None:
    t = np.arange(0.0, 10.0, 0.1)
    v = np.where(t < 2.0, 0.0, 0.2)
    v = np.where((t >= 6.0) & (t < 6.5), 0.1, v)  # a 0.5 s blip: not held long enough
    w = np.where(t >= 8.0, 0.2, 0.0)  # below the 0.3 rad/s jump
    steps = find_steps(t, v, w)
    assert [(s.axis, s.before, s.after) for s in steps] == [("v", 0.0, 0.2), ("v", 0.1, 0.2)]
    assert steps[0].t_start_s == pytest.approx(2.0) and steps[0].t_end_s == pytest.approx(6.0)


def test_step_response_golden_numbers() -> None:
    t = np.linspace(0.0, 6.0, 6001)
    step = Step(axis="v", t_start_s=1.0, t_end_s=6.0, before=0.0, after=0.2)
    tau = 0.1  # first order: rise time tau ln 9, no overshoot, settles 10 % under the command
    y1 = np.where(t < 1.0, 0.0, 0.18 * (1 - np.exp(-(t - 1.0) / tau)))
    r1 = step_response(t, y1, step)
    assert r1.rise_time_s == pytest.approx(tau * math.log(9.0), abs=2e-3)
    assert r1.overshoot_pct == pytest.approx(0.0, abs=1e-6)
    assert r1.ss_error == pytest.approx(-0.02, abs=1e-6)
    zeta, wn = 0.5, 10.0  # second order: overshoot exp(-zeta pi / sqrt(1 - zeta^2)) = 16.3 %
    wd, s = wn * math.sqrt(1 - zeta**2), np.clip(t - 1.0, 0.0, None)
    y2 = 0.2 * (
        1
        - np.exp(-zeta * wn * s) * (np.cos(wd * s) + zeta / math.sqrt(1 - zeta**2) * np.sin(wd * s))
    )
    r2 = step_response(t, y2, step)
    assert r2.overshoot_pct == pytest.approx(
        100 * math.exp(-zeta * math.pi / math.sqrt(1 - zeta**2)), abs=0.1
    )
    flat = step_response(t, np.zeros_like(t), step)
    assert math.isnan(flat.rise_time_s) and flat.ss_error == pytest.approx(-0.2)  # fmt: skip


def test_rolling_agreement_counts_active_samples_in_the_window() -> None:
    t = np.arange(10.0)
    ok = np.array([1, 1, 1, 1, 0, 0, 0, 0, 1, 1], bool)
    active = np.array([1, 1, 1, 1, 1, 0, 0, 1, 1, 1], bool)
    frac = rolling_agreement(t, ok, active, window_s=2.0)  # samples i-1, i, i+1
    np.testing.assert_allclose(frac[[0, 3, 5, 6, 8]], [1.0, 2 / 3, 0.0, 0.0, 2 / 3])
    assert math.isnan(rolling_agreement(t, ok, np.zeros(10, bool), window_s=2.0)[0])


def test_param_rows_read_intervals_and_status(tmp_path: Path) -> None:
    path = tmp_path / "p.yaml"
    doc = {
        "format": "sim2real.sysid/1",
        "robot": ROBOT,
        "parameters": {
            "delay_s": {"value": 0.15, "std": 0.002, "ci95": [0.146, 0.154], "unit": "s",
                        "status": "fitted"},
            "accel_lim_v_mps2": {"value": float("inf"), "std": None, "ci95": None,
                                 "status": "fixed"},
        },
    }  # fmt: skip
    path.write_text(yaml.safe_dump(doc))
    rows = {r.name: r for r in param_rows(DriveParams(), DriveParams(delay_s=0.15), path)}
    assert len(rows) == len(DriveParams.names())
    assert rows["delay_s"].ci95 == (0.146, 0.154) and rows["delay_s"].std == 0.002
    assert rows["delay_s"].status == "fitted" and rows["delay_s"].default == 0.0
    assert rows["accel_lim_v_mps2"].status == "fixed" and rows["accel_lim_v_mps2"].ci95 is None
    assert rows["coulomb_w_nm"].unit == "N m" and rows["viscous_v_ns_per_m"].unit == "N s/m"


def test_param_rows_read_the_file_through_the_one_parser(tmp_path: Path) -> None:
    """robots.params.load_params_document: a bad file is named in one sentence."""
    from robots.errors import ParamsFileError

    bad = tmp_path / "bad.yaml"
    bad.write_text("parameters: [unclosed\n")
    with pytest.raises(ParamsFileError, match=r"bad\.yaml' is not valid YAML"):
        param_rows(DriveParams(), DriveParams(), bad)
    with pytest.raises(ParamsFileError, match="is a folder"):
        param_rows(DriveParams(), DriveParams(), tmp_path)


def test_page_is_self_contained_and_escapes_text(tmp_path: Path) -> None:
    log = write_log(tmp_path / "a&b<c>.mcap", duration_s=12.0)
    trace = read_trace(log)
    runs = []
    for label, p in (("spec <defaults>", spec().drive), ("fit", hidden_params())):
        sim = replay(trace, robot=ROBOT, params=p, engine="reduced")
        runs.append(ReportRun(label=label, replay=sim, agreement=measure_agreement(trace, sim)))
    files = write_report(
        tmp_path / "r.html",
        ReportInput(trace=trace, runs=runs, provenance=[("command line", "sim2real agree 'x'")]),
    )
    page = files.html.read_text(encoding="utf-8")
    assert "a&amp;b&lt;c&gt;.mcap" in page and "spec &lt;defaults&gt;" in page
    assert "<c>" not in page
    assert "Content-Security-Policy" in page and "default-src 'none'" in page
    assert not re.search(r"(src|href)=\"(?!data:)", page)  # every resource is inline
    images = re.findall(r'src="data:image/png;base64,([A-Za-z0-9+/=]+)"', page)
    assert len(images) == 4 == len(files.images)
    for b64, png in zip(images, sorted(files.images, key=lambda p: p.name), strict=False):
        assert base64.b64decode(b64)[:4] == b"\x89PNG"
        assert png.stat().st_size > 5000
    assert "Step-like segments" in page and "Provenance" in page and "How to read" in page
    with pytest.raises(Sim2RealValueError, match="runs is empty"):
        write_report(tmp_path / "x.html", ReportInput(trace=trace, runs=()))
    assert not (tmp_path / "x.html").exists()


@given(
    width=st.floats(0.0, 2.0),
    span=st.floats(0.01, 10.0),
    centre=st.floats(-5.0, 5.0),
)
def test_a_band_is_drawn_wide_enough_to_see_and_never_narrower(
    width: float, span: float, centre: float
) -> None:
    lo, hi = np.array([centre - width / 2]), np.array([centre + width / 2])
    lo_d, hi_d, widened = visible_band(lo, hi, span)
    assert lo_d[0] <= lo[0] + 1e-12 and hi_d[0] >= hi[0] - 1e-12  # the true band inside
    assert hi_d[0] - lo_d[0] == pytest.approx(max(width, MIN_BAND_SHARE * span))
    assert (lo_d[0] + hi_d[0]) / 2 == pytest.approx(centre, abs=1e-9)  # centred on it
    assert widened == (width < MIN_BAND_SHARE * span)


def test_the_band_legend_gives_the_true_width_and_says_when_drawn_wider() -> None:
    t = np.linspace(0.0, 1.0, 5)
    band = Band(lo_v=t, hi_v=t + 0.0015, lo_w=t, hi_w=t + 0.054, label="90 % band (N=10)")
    text = band_legend(band, widened=True)
    assert text.startswith("90 % band (N=10): median 0.0015 m/s, 0.054 rad/s wide")
    assert text.endswith(f"(drawn >= {100 * MIN_BAND_SHARE:g} % of the axis to be seen)")
    assert "drawn" not in band_legend(band, widened=False)
