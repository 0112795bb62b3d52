"""Write the README's performance table from the figures of one ``make bench`` run.

Each benchmark appends its headline figures to ``benchmarks/.results.jsonl`` (see
``_timing.record``); ``make bench`` empties that file first and runs this script last, which
replaces the block between the ``perf-table`` markers of README.md with a table naming the
machine and the date.
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import sys

from _timing import QUICK, REPO, RESULTS, machine

START, END = "<!-- perf-table:start -->", "<!-- perf-table:end -->"


def table(rows: list[dict[str, object]], failed: list[str], elapsed_s: float | None = None) -> str:
    when = dt.datetime.now(dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    load = os.getloadavg()[0]
    cores = os.cpu_count() or 1
    notes = []
    if QUICK:
        notes.append("**quick run** (`BENCH_QUICK=1`: fewer repeats, noisier figures)")
    if load > 0.5 * cores:
        notes.append(
            f"**measured under load** (load average {load:.1f} on {cores} cores: wall times "
            "include the queue; CPU figures are the better guide)"
        )
    if failed:
        notes.append("benchmarks that failed (no figures): " + ", ".join(f"`{f}`" for f in failed))
    took = "" if elapsed_s is None else f"; the run took {elapsed_s / 60:.1f} min"
    lines = [
        START,
        f"Measured by one `make bench` run on {machine()}, {when} "
        f"(load average {load:.1f} at the end{took}). Ratios alternate ours and the "
        "baseline in one process with the same repeat count; command times are whole processes.",
        *(["", "Note: " + "; ".join(notes) + "."] if notes else []),
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
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--failed", default="", help="space-separated benchmarks that failed")
    parser.add_argument(
        "--elapsed-s", type=float, default=None, help="the whole run's wall time, s (make bench)"
    )
    args = parser.parse_args()
    failed = args.failed.split()
    if not RESULTS.is_file():
        print(f"no results in {RESULTS}; run `make bench`", file=sys.stderr)
        return 1
    rows = [json.loads(line) for line in RESULTS.read_text(encoding="utf-8").splitlines() if line]
    readme = REPO / "README.md"
    text = readme.read_text(encoding="utf-8")
    block = table(rows, failed, args.elapsed_s)
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
