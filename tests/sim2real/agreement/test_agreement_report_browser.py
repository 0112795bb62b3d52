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
    assert state["height"] > 2000
    assert state["headline"].endswith("%")
    png = browser.screenshot()
    shot = imread(io.BytesIO(png))
    assert shot.shape[0] >= 600 and shot.shape[1] >= 1000  # the 1200x900 window
    # non-trivial: many distinct colours and real contrast, not a blank page
    flat = np.round(shot[..., :3] * 255).astype(int).reshape(-1, 3)
    assert len(np.unique(flat[::7], axis=0)) > 50
    assert float(shot[..., :3].std()) > 0.05
    (report.parent / "screenshot.png").write_bytes(png)


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
