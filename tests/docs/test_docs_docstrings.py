"""The docstrings use numpydoc's section headers, which the API reference parses."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
#: A header numpydoc does not know, underlined: the reference would show its body as prose.
_WRONG = re.compile(r"(?m)^\s*(Example|Parameter|Return|Yield|Raise|Note|Reference)\n\s*-{3,}\n")


def test_no_singular_section_headers() -> None:
    wrong = []
    for package in ("sysid", "robots", "randomizers", "sim2real"):
        for path in sorted((ROOT / package).rglob("*.py")):
            for m in _WRONG.finditer(path.read_text(encoding="utf-8")):
                wrong.append(f"{path.relative_to(ROOT)}: {m.group(1)}")
    assert not wrong, "use numpydoc's plural headers (Examples, Parameters, ...): " + str(wrong)
