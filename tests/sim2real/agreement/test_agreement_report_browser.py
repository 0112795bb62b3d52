"""The HTML report in a real headless Chromium: renders, images load, no console errors."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest
from _agreement_fixtures import HIDDEN, ROBOT, write_log, write_params
from _cdp_browser import Browser, find_browser

from sim2real.cli import main

pytestmark = [pytest.mark.browser, pytest.mark.slow]

_IMAGES_JS = """JSON.stringify({
  title: document.title,
  images: [...document.images].map(i => [i.complete, i.naturalWidth, i.naturalHeight]),
  resources: performance.getEntriesByType('resource').map(e => e.name),
  height: document.documentElement.scrollHeight,
  headline: document.querySelector('.card .big') && document.querySelector('.card .big').textContent
})"""


@pytest.fixture(scope="module")
def browser(tmp_path_factory: pytest.TempPathFactory):  # type: ignore[no-untyped-def]
    exe = find_browser()
    if exe is None:
        pytest.skip(
            "no headless browser found (chromium, chromium-browser, google-chrome); "
            "install Debian's 'chromium' package (.ci/run does) to run the report browser test"
        )
    with Browser(exe, tmp_path_factory.mktemp("chromium-profile")) as b:
        yield b


@pytest.fixture(scope="module")
def report(tmp_path_factory: pytest.TempPathFactory) -> Path:
    tmp = tmp_path_factory.mktemp("report")
    log = write_log(tmp / "val.mcap", duration_s=20.0)
    params = write_params(tmp / "params.yaml", HIDDEN)
    out = tmp / "report.html"
    code = main(
        ["agree", str(log), "--robot", ROBOT, "--engine", "reduced", "--params", str(params),
         "--ensemble", "4", "--report", str(out)]
    )  # fmt: skip
    assert code == 0
    return out


def test_report_renders_with_all_images_and_no_errors(browser: Browser, report: Path) -> None:
    import json

    from matplotlib.image import imread

    browser.load(report.as_uri())
    state = json.loads(browser.evaluate(_IMAGES_JS))
    assert browser.errors() == []
    assert state["title"] == "sim2real agreement report"
    assert len(state["images"]) == 4
    for complete, width, height in state["images"]:
        assert complete and width >= 800 and height >= 200
    assert state["resources"] == []  # nothing fetched: self-contained
    assert state["height"] > 1500  # the details (tables, definitions) are collapsed
    assert state["headline"].endswith("%")
    png = browser.screenshot()
    shot = imread(io.BytesIO(png))
    assert shot.shape[0] >= 600 and shot.shape[1] >= 1000  # the 1200x900 window
    # non-trivial: many distinct colours and real contrast, not a blank page
    flat = np.round(shot[..., :3] * 255).astype(int).reshape(-1, 3)
    assert len(np.unique(flat[::7], axis=0)) > 50
    assert float(shot[..., :3].std()) > 0.05
    (report.parent / "screenshot.png").write_bytes(png)


_FIRST_SCREEN_JS = """JSON.stringify({
  first: document.querySelector('main').firstElementChild.id,
  boxes: Object.fromEntries(['verdict', 'main-plot'].map(id => {
    const r = document.getElementById(id).getBoundingClientRect();
    return [id, [r.left, r.top, r.right, r.bottom]];
  })),
  plot: [...document.querySelectorAll('#main-plot img')].map(
    i => { const r = i.getBoundingClientRect(); return [i.complete, i.naturalWidth, r.height]; }),
  verdict: document.getElementById('verdict').innerText,
  closed: [...document.querySelectorAll('details')].filter(d => !d.open).map(
    d => d.querySelector('summary').textContent),
  params_visible: [...document.querySelectorAll('details table')].some(
    t => t.checkVisibility()),
  viewport: [window.innerWidth, window.innerHeight],
  page_width: document.documentElement.scrollWidth,
  client_width: document.documentElement.clientWidth
})"""


def _band_pixels(shot: np.ndarray, box: list[float]) -> int:
    """Pixels of the band's fill (vermillion #D55E00 at alpha 0.22 on white) inside ``box``."""
    left, top, right, bottom = (round(x) for x in box)
    rgb = np.round(shot[top:bottom, left:right, :3] * 255)
    fill = 255 * 0.78 + 0.22 * np.array([0xD5, 0x5E, 0x00])
    return int((np.abs(rgb - fill).max(axis=-1) <= 6).sum())


@pytest.fixture(scope="module")
def wide_report(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A report whose band is wide enough to see (the randomisation spread 10x)."""
    tmp = tmp_path_factory.mktemp("wide")
    log = write_log(tmp / "val.mcap", duration_s=20.0)
    params = write_params(tmp / "params.yaml", HIDDEN)
    out = tmp / "report.html"
    code = main(
        ["agree", str(log), "--robot", ROBOT, "--engine", "reduced", "--params", str(params),
         "--ensemble", "8", "--spread", "10", "--report", str(out)]
    )  # fmt: skip
    assert code == 0
    return out


def test_first_screen_holds_the_verdict_and_the_band_plot(
    browser: Browser, wide_report: Path
) -> None:
    """At 1280x800 the verdict and the whole main plot (with its band) are on the first screen."""
    import json

    from matplotlib.image import imread

    browser.call(
        "Emulation.setDeviceMetricsOverride", width=1280, height=800, deviceScaleFactor=1,
        mobile=False,
    )  # fmt: skip
    try:
        browser.load(wide_report.as_uri())
        state = json.loads(browser.evaluate(_FIRST_SCREEN_JS))
        png = browser.screenshot()
    finally:
        browser.call("Emulation.clearDeviceMetricsOverride")
    assert browser.errors() == []
    assert state["viewport"] == [1280, 800]
    assert state["page_width"] <= state["client_width"]  # no sideways scrolling
    assert state["first"] == "verdict"  # the page starts with the verdict
    v_left, v_top, v_right, v_bottom = state["boxes"]["verdict"]
    assert v_left >= 0
    p_left, p_top, p_right, p_bottom = state["boxes"]["main-plot"]
    assert 0 <= v_top < v_bottom <= p_top  # verdict first, the plot right under it
    assert p_bottom <= 800 and p_right <= 1280 and v_right <= 1280  # both wholly on screen
    [(complete, width, shown_h)] = state["plot"]
    assert complete and width >= 1000 and shown_h >= 350  # a real plot, not a thumbnail
    text = state["verdict"]
    for words in ("AGREEMENT", "COVERAGE OF THE", "TIMING", "Next step:", "of the real samples"):
        assert words.lower() in text.lower(), words
    assert "sim leads real by" in text or "sim lags real by" in text or "in step" in text
    # details are collapsed: parameter table, segments, provenance, definitions
    assert {"Drive parameters", "Step-like segments", "Provenance"} <= set(state["closed"])
    assert not state["params_visible"]
    (wide_report.parent / "first_screen.png").write_bytes(png)
    shot = imread(io.BytesIO(png))
    assert shot.shape[:2] == (800, 1280)
    axes = [p_left, p_top + 45, p_right, p_bottom]  # below the legend (its swatch is no band)
    assert _band_pixels(shot, axes) > 2000  # the band is drawn, visibly


def test_the_check_catches_a_broken_page(browser: Browser, tmp_path: Path) -> None:
    """Negative control: a broken image and a script error are detected."""
    bad = tmp_path / "bad.html"
    bad.write_text(
        "<!DOCTYPE html><html><head><title>bad</title></head><body>"
        '<img src="data:image/png;base64,AAAA"><script>undefinedFunction()</script></body></html>',
        encoding="utf-8",
    )
    browser.load(bad.as_uri())
    import json

    state = json.loads(browser.evaluate(_IMAGES_JS))
    assert state["images"][0][1] == 0
    assert browser.errors()


def test_pngs_are_written_next_to_the_report(report: Path) -> None:
    names = sorted(p.name for p in report.parent.glob("report_*.png"))
    assert names == [
        "report_errors.png",
        "report_rolling.png",
        "report_timeseries.png",
        "report_zoom.png",
    ]
    for p in report.parent.glob("report_*.png"):
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
