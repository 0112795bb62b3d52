"""Regenerate docs/spec-format.md from robots.params.SCHEMA (``python scripts/gen_spec_format.py``)."""

from __future__ import annotations

from pathlib import Path

from robots.specdoc import spec_format_markdown

PAGE = Path(__file__).resolve().parents[1] / "docs" / "spec-format.md"

if __name__ == "__main__":
    PAGE.write_text(spec_format_markdown(), encoding="utf-8")
    print(f"wrote {PAGE}")
