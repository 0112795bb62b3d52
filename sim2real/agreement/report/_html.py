"""HTML rendering of the agreement report: one self-contained page (inline CSS, base64 PNGs).

The page carries a Content-Security-Policy that forbids every network fetch (only ``data:``
images and inline styles are allowed), so it renders identically offline and never phones
home. All text is HTML-escaped.
"""

from __future__ import annotations

import base64
import html
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from sim2real.agreement.verdict import AgreementVerdict

__all__ = [
    "Figure",
    "FleetEntry",
    "HeadlineCard",
    "Stat",
    "Table",
    "Verdict",
    "render_fleet_page",
    "render_page",
]

_CSS = """
body{font-family:system-ui,-apple-system,"Segoe UI",Roboto,sans-serif;margin:0;color:#1d1d1f;
background:#f6f7f9;line-height:1.45}
main{max-width:1140px;margin:0 auto;padding:24px}
h1{font-size:1.6rem;margin:0 0 4px}h2{font-size:1.2rem;margin:28px 0 8px;border-bottom:1px solid
#ddd;padding-bottom:4px}.sub{color:#555;margin:0 0 16px}
.cards{display:flex;gap:16px;flex-wrap:wrap}.card{background:#fff;border-radius:10px;
padding:14px 18px;box-shadow:0 1px 3px rgba(0,0,0,.12);min-width:200px;flex:1}
.card .label{font-size:.85rem;color:#555;text-transform:uppercase;letter-spacing:.04em}
.card .big{font-size:2.4rem;font-weight:700}.card .small{font-size:.9rem;color:#444}
.good{color:#1b7e3c}.mid{color:#b36b00}.bad{color:#b3261e}
table{border-collapse:collapse;background:#fff;width:100%;font-size:.88rem;
box-shadow:0 1px 3px rgba(0,0,0,.08)}th,td{padding:5px 9px;border-bottom:1px solid #eee;
text-align:right}.nowrap td{white-space:nowrap}.wrap td{word-break:break-all;text-align:left}
.wrap td:first-child{white-space:nowrap;word-break:normal}th:first-child,td:first-child{text-align:left}th{background:#eef0f3}
figure{margin:12px 0;background:#fff;padding:8px;border-radius:8px;
box-shadow:0 1px 3px rgba(0,0,0,.08)}figure img{width:100%;height:auto;display:block}
figcaption{font-size:.85rem;color:#444;margin-top:4px}.note{font-size:.85rem;color:#555}
code{background:#eef0f3;padding:1px 4px;border-radius:3px;word-break:break-all}
main{padding:14px 24px}h1{font-size:1.35rem}.sub{margin:0 0 8px;font-size:.85rem}
#verdict{background:#fff;border-radius:10px;box-shadow:0 1px 3px rgba(0,0,0,.12);
padding:10px 16px 10px}#verdict .stats{display:flex;gap:18px;flex-wrap:wrap}
#verdict .stat{flex:1;min-width:220px}#verdict .stat .big{font-size:1.7rem;font-weight:700}
#verdict .stat .label{font-size:.78rem;color:#555;text-transform:uppercase;letter-spacing:.04em}
#verdict .stat p{margin:2px 0 0;font-size:.86rem}
#verdict .next{margin:8px 0 0;padding:6px 10px;background:#fff8e1;border-left:4px solid #b36b00;
font-size:.92rem}#verdict .next.ok{background:#eaf6ee;border-left-color:#1b7e3c}
figure.lead{margin:8px 0 0;padding:4px 8px}figure.lead figcaption{margin-top:0}
details{margin:14px 0;background:#fff;border-radius:8px;padding:4px 12px;
box-shadow:0 1px 3px rgba(0,0,0,.08)}summary{cursor:pointer;font-weight:600;padding:6px 0}
details h2{margin-top:10px}.card{overflow-wrap:anywhere}
#verdict p{overflow-wrap:anywhere}#verdict .next p{margin:0}
#verdict .reasons{margin:4px 0 0;padding-left:20px;font-size:.86rem}
#verdict details.why{margin:0;padding:0;box-shadow:none;background:none}
#verdict details.why summary{padding:0;font-size:.84rem;font-weight:400;color:#555}
section.log{background:#fff;border-radius:10px;box-shadow:0 1px 3px rgba(0,0,0,.12);
padding:6px 16px 10px;margin:14px 0}section.log h2{margin-top:6px}
section.log .next{margin:6px 0 0;padding:6px 10px;background:#fff8e1;
border-left:4px solid #b36b00}section.log .next.ok{background:#eaf6ee;border-left-color:#1b7e3c}
section.log .reasons{margin:4px 0 0;padding-left:20px;font-size:.86rem}
"""

_CSP = "default-src 'none'; img-src data:; style-src 'unsafe-inline'"


@dataclass(frozen=True, kw_only=True)
class HeadlineCard:
    """A big-number card: label, value in 0..1 (shown in %, or ``text``), a line of detail."""

    label: str
    fraction: float
    detail: str
    text: str = ""


@dataclass(frozen=True, kw_only=True)
class Table:
    """A titled table of already-formatted cells."""

    title: str
    header: Sequence[str]
    rows: Sequence[Sequence[str]]
    note: str = ""
    wrap: bool = False


@dataclass(frozen=True, kw_only=True)
class Figure:
    """A PNG figure with its caption."""

    title: str
    png: bytes
    caption: str


@dataclass(frozen=True, kw_only=True)
class Stat:
    """One figure of the verdict: a label, its value as text, a grade fraction, one sentence."""

    label: str
    value: str
    fraction: float
    sentence: str


@dataclass(frozen=True, kw_only=True)
class Verdict:
    """The report's first section: the figures that matter, the verdict and the next step.

    ``headline`` and ``reasons`` are the verdict's sentences; ``ok`` marks a next step that is
    "nothing to fix" (drawn green instead of amber).
    """

    stats: Sequence[Stat]
    next_step: str
    ok: bool = False
    headline: str = ""
    reasons: Sequence[str] = ()
    notes: Sequence[str] = ()


@dataclass(frozen=True, kw_only=True)
class FleetEntry:
    """One log of a fleet page: its name and verdict, or why it was left out.

    ``verdict`` is the log's :class:`sim2real.agreement.verdict.AgreementVerdict` (None with
    ``error``, which says why the log could not be used); ``notes`` are its data notes.
    """

    name: str
    verdict: AgreementVerdict | None = None
    error: str = ""
    notes: Sequence[str] = ()


def _e(text: object) -> str:
    return html.escape(str(text), quote=True)


def _grade(fraction: float) -> str:
    if not math.isfinite(fraction):
        return ""
    return "good" if fraction >= 0.9 else "mid" if fraction >= 0.7 else "bad"


def _verdict(v: Verdict, title: str, subtitle: str) -> str:
    stats = "".join(
        f'<div class="stat"><div class="label">{_e(st.label)}</div>'
        f'<div class="big {_grade(st.fraction)}">{_e(st.value)}</div>'
        f"<p>{_e(st.sentence)}</p></div>"
        for st in v.stats
    )
    cls = "next ok" if v.ok else "next"
    headline = f'<p class="headline"><b>Verdict:</b> {_e(v.headline)}</p>' if v.headline else ""
    return (
        f'<section id="verdict"><h1>{_e(title)}</h1><p class="sub">{_e(subtitle)}</p>'
        f'<div class="stats">{stats}</div><div class="{cls}">{headline}'
        f'<p class="step"><b>Next step:</b> {_e(v.next_step)}</p>{_why(v)}</div></section>'
    )


def _why(v: Verdict) -> str:
    """The verdict's reasons and the data notes, collapsed (the first screen keeps the plot)."""
    if not (v.reasons or v.notes):
        return ""
    counts = [f"{len(v.reasons)} finding{'s' * (len(v.reasons) != 1)}"] if v.reasons else []
    counts += [f"{len(v.notes)} note{'s' * (len(v.notes) != 1)}"] if v.notes else []
    reasons = "".join(f"<li>{_e(r)}</li>" for r in v.reasons)
    return (
        f'<details class="why"><summary>Why: {", ".join(counts)}</summary>'
        + (f'<ul class="reasons">{reasons}</ul>' if reasons else "")
        + "".join(f'<p class="note">note: {_e(n)}</p>' for n in v.notes)
        + "</details>"
    )


def _card(card: HeadlineCard) -> str:
    value = f"{100 * card.fraction:.1f} %" if math.isfinite(card.fraction) else "n/a"
    value = card.text or value
    return (
        f'<div class="card"><div class="label">{_e(card.label)}</div>'
        f'<div class="big {_grade(card.fraction)}">{_e(value)}</div>'
        f'<div class="small">{_e(card.detail)}</div></div>'
    )


def _table(table: Table) -> str:
    head = "".join(f"<th>{_e(h)}</th>" for h in table.header)
    body = "".join(
        "<tr>" + "".join(f"<td>{_e(c)}</td>" for c in row) + "</tr>" for row in table.rows
    )
    note = f'<p class="note">{_e(table.note)}</p>' if table.note else ""
    cls = "wrap" if table.wrap else "nowrap"
    return (
        f"<h2>{_e(table.title)}</h2>{note}"
        f'<table class="{cls}"><thead><tr>{head}</tr></thead>'
        f"<tbody>{body}</tbody></table>"
    )


def _figure(fig: Figure, *, lead: bool = False) -> str:
    data = base64.b64encode(fig.png).decode("ascii")
    img = (
        f'<img alt="{_e(fig.title)}" src="data:image/png;base64,{data}">'
        f"<figcaption>{_e(fig.caption)}</figcaption>"
    )
    if lead:  # the main plot: no heading, right under the verdict
        return f'<figure class="lead" id="main-plot">{img}</figure>'
    return f"<h2>{_e(fig.title)}</h2><figure>{img}</figure>"


def _head(title: str) -> str:
    """The page's head, up to the opening ``<main>`` (offline policy, inline style)."""
    return (
        '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">\n'
        f'<meta http-equiv="Content-Security-Policy" content="{_CSP}">\n'
        '<meta name="viewport" content="width=device-width, initial-scale=1">\n'
        f"<title>{_e(title)}</title><style>{_CSS}</style></head><body><main>"
    )


def _details(summary: str, body: str) -> str:
    return f"<details><summary>{_e(summary)}</summary>{body}</details>"


def render_page(
    *,
    title: str,
    subtitle: str,
    verdict: Verdict,
    lead: Figure,
    cards: Sequence[HeadlineCard],
    summary: Table,
    figures: Sequence[Figure],
    tables: Sequence[Table],
    definitions: Mapping[str, str],
) -> str:
    """The whole report page as one HTML string (no external resources).

    Layout: the verdict (title, the figures that matter, the next step) and the main plot
    fill the first screen; then the headline cards, the agreement figures and the other
    plots; each of ``tables`` (parameters, segments, provenance) and the definitions are
    collapsed ``<details>`` blocks below.
    """
    defs = "".join(f"<li><b>{_e(k)}</b>: {_e(v)}</li>" for k, v in definitions.items())
    parts = [
        _head(title),
        _verdict(verdict, title, subtitle),
        _figure(lead, lead=True),
        '<h2>Agreement</h2><div class="cards">' + "".join(_card(c) for c in cards) + "</div>",
        _table(summary),
        *(_figure(f) for f in figures),
        *(_details(t.title, _table(t)) for t in tables),
        _details("How to read this report", f'<ul class="note">{defs}</ul>'),
        "</main></body></html>",
    ]
    return "\n".join(parts) + "\n"


def _fleet_entry(i: int, entry: FleetEntry) -> str:
    """One log's section: the verdict's headline, reasons and next step (or why it was left
    out), and its notes."""
    v = entry.verdict
    if v is None:
        body = f'<p class="headline"><b>Left out:</b> {_e(entry.error)}</p>'
    else:
        reasons = "".join(f"<li>{_e(r)}</li>" for r in v.reasons)
        body = (
            f'<p class="headline"><b>Verdict:</b> {_e(v.headline)}</p>'
            + (f'<ul class="reasons">{reasons}</ul>' if reasons else "")
            + f'<div class="{"next ok" if v.ok else "next"}"><p class="step">'
            f"<b>Next step:</b> {_e(v.next_step)}</p></div>"
        )
    notes = "".join(f'<p class="note">note: {_e(n)}</p>' for n in entry.notes)
    return f'<section class="log" id="log-{i}"><h2>{_e(entry.name)}</h2>{body}{notes}</section>'


def render_fleet_page(
    *, title: str, subtitle: str, summary: Table, pooled: str, entries: Sequence[FleetEntry]
) -> str:
    """The page of a multi-log run: the fleet table, the pooled sentence, then one section per
    log with its verdict (no external resources; all text escaped)."""
    parts = [
        _head(title),
        f'<h1>{_e(title)}</h1><p class="sub">{_e(subtitle)}</p>',
        _table(summary),
        f'<p class="headline" id="pooled">{_e(pooled)}</p>' if pooled else "",
        *(_fleet_entry(i, e) for i, e in enumerate(entries)),
        "</main></body></html>",
    ]
    return "\n".join(parts) + "\n"
