"""docs/spec-format.md is generated from the schema and up to date; its key tables are right."""

from __future__ import annotations

from pathlib import Path

from robots.params import SCHEMA
from robots.spec import load_spec
from robots.specdoc import SECTIONS, spec_format_markdown

ROOT = Path(__file__).resolve().parents[2]


def test_page_is_up_to_date() -> None:
    page = (ROOT / "docs" / "spec-format.md").read_text(encoding="utf-8")
    assert page == spec_format_markdown(), "run: python scripts/gen_spec_format.py"


def test_page_lists_every_drive_field_and_spec_key() -> None:
    page = spec_format_markdown()
    for name, f in SCHEMA.items():
        assert f"| {name} | {f.unit} | {f.coord} |" in page
    d = load_spec("turtlebot2").to_dict()
    assert [k for k, _, _ in SECTIONS[""]] == list(d)
    for section in ("base", "wheels", "limits", "lidar", "depth_camera", "odometry"):
        keys = {k for k, _, _ in SECTIONS[section]}
        assert keys == set(d[section]) - {"size_m", "radius_m", "height_m"} or keys == set(
            d[section]
        )
    assert {k for k, _, _ in SECTIONS["casters[]"]} == set(d["casters"][0])
