"""Write the README's performance table from the figures of one ``make bench`` run.

Each benchmark appends its headline figures to ``benchmarks/.results.jsonl`` (see
``_timing.record``); ``make bench`` empties that file first and runs this script last, which
replaces the block between the ``perf-table`` markers of README.md with a table naming the
machine and the date.
"""

from __future__ import annotations

import datetime as dt
import json
import os
import sys

from _timing import REPO, RESULTS, machine

START, END = "<!-- perf-table:start -->", "<!-- perf-table:end -->"


def table(rows: list[dict[str, object]]) -> str:
    when = dt.datetime.now(dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    lines = [
        START,
        f"Measured by one `make bench` run on {machine()}, {when} "
        f"(load average {os.getloadavg()[0]:.1f} at the end). Ratios alternate ours and the "
        "baseline in one process with the same repeat count; command times are whole processes.",
        "",
        "| area | figure | measured | target | met |",
        "|---|---|---|---|---|",
    ]
    for r in rows:
        met = {True: "yes", False: "**no**", None: "-"}[r["met"]]  # type: ignore[index]
        lines.append(f"| {r['bench']} | {r['figure']} | {r['value']} | {r['target']} | {met} |")
    lines.append(END)
    return "\n".join(lines)


def main() -> int:
    if not RESULTS.is_file():
        print(f"no results in {RESULTS}; run `make bench`", file=sys.stderr)
        return 1
    rows = [json.loads(line) for line in RESULTS.read_text(encoding="utf-8").splitlines() if line]
    readme = REPO / "README.md"
    text = readme.read_text(encoding="utf-8")
    block = table(rows)
    if START in text and END in text:
        head, rest = text.split(START, 1)
        text = head + block + rest.split(END, 1)[1]
    else:
        text = text.rstrip("\n") + "\n\n## Performance\n\n" + block + "\n"
    tmp = readme.with_suffix(".md.tmp")
    tmp.write_text(text, encoding="utf-8")
    tmp.replace(readme)
    print(f"wrote the performance table ({len(rows)} figures) to {readme}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
