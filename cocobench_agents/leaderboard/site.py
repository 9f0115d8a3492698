"""The leaderboard as a static site: `index.html` (a sortable table), its script and style
beside it, and `leaderboard.json`. Nothing is fetched from elsewhere: the page works opened
from disk and on any static host."""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any

import jinja2

from benchmark_adapter.vocabulary import DIMENSIONS
from cocobench_agents.leaderboard.rows import Row
from cocobench_agents.reports.stats import Estimate

PAGE = """<!doctype html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta http-equiv="Content-Security-Policy"
      content="default-src 'none'; script-src 'self'; style-src 'self'; img-src 'self'">
<title>CoCoBench leaderboard</title>
<link rel="stylesheet" href="leaderboard.css">
<script src="leaderboard.js" defer></script>
</head>
<body>
<h1>CoCoBench leaderboard</h1>
<p>One row per model × scaffold (planner, prompt suite, settings) × condition. Every episode
of a row was replayed step by step in the embedded simulator and its metrics recomputed
(<code>cocobench verify</code>); only rows that verify, run with the reference's settings, are
ranked (within their condition). Intervals: {{ confidence }} bootstrap, resampling instances
with all their epochs. Click a column to sort.</p>
<table id="leaderboard">
<thead><tr>
{% for key, title, kind in columns -%}
<th data-key="{{ key }}" data-kind="{{ kind }}" aria-sort="none" tabindex="0">{{ title }}</th>
{% endfor %}</tr></thead>
<tbody>
{% for row in rows %}<tr class="{{ row.badge }}">
{% for cell in row.cells -%}
<td data-value="{{ cell.sort }}"{% if cell.get("title") %} title="{{ cell.title }}"{% endif %}>
{%- if cell.get("href") %}<a href="{{ cell.href }}">{{ cell.text }}</a>
{%- elif cell.get("badge") %}<span class="badge {{ cell.badge }}">{{ cell.text }}</span>
{%- else %}{{ cell.text }}{% endif %}</td>
{% endfor %}</tr>
{% endfor %}</tbody>
</table>
<p class="legend">SR: task success rate. CS: construct score (how the team coordinated, not
whether it finished), CS_D1–D4 per coordination dimension. pass^k: the chance that k fresh
episodes of an instance all succeed (where every instance has k epochs). legal: plans with no
illegal step. Tokens and dollars per episode (dollars where the model is priced). Badges:
verified, mismatch (an episode differs from its replay), unverifiable (an AI2-THOR episode, a
missing trajectory), refused (a bundle that does not cover what it declares).</p>
</body>
</html>
"""

STYLE = """body { font: 14px/1.4 system-ui, sans-serif; margin: 2em; color: #222; }
table { border-collapse: collapse; }
th, td { padding: 4px 8px; border-bottom: 1px solid #ddd; text-align: right; white-space: nowrap; }
th { cursor: pointer; background: #f4f4f4; position: sticky; top: 0; }
th[aria-sort="ascending"]::after { content: " ▲"; }
th[aria-sort="descending"]::after { content: " ▼"; }
th:nth-child(-n+8), td:nth-child(-n+8) { text-align: left; }
tr.mismatch, tr.unverifiable, tr.refused { color: #888; }
.badge { border-radius: 3px; padding: 1px 6px; color: #fff; font-size: 12px; }
.badge.verified { background: #2e7d32; } .badge.mismatch { background: #c62828; }
.badge.unverifiable { background: #f9a825; color: #222; } .badge.refused { background: #6a1b9a; }
.legend { color: #555; max-width: 60em; }
"""

SCRIPT = """// Sort the table by a column: numbers by value, text by its order; empty cells last.
document.addEventListener("DOMContentLoaded", () => {
  const table = document.getElementById("leaderboard");
  const headers = Array.from(table.tHead.rows[0].cells);
  headers.forEach((th, index) => {
    const sort = () => {
      const descending = th.getAttribute("aria-sort") !== "descending";
      headers.forEach(h => h.setAttribute("aria-sort", "none"));
      th.setAttribute("aria-sort", descending ? "descending" : "ascending");
      const numeric = th.dataset.kind === "number";
      const body = table.tBodies[0];
      const rows = Array.from(body.rows);
      const value = row => row.cells[index].dataset.value;
      rows.sort((a, b) => {
        const x = value(a), y = value(b);
        if (x === "" || y === "") return (x === "") - (y === "");
        const order = numeric ? Number(x) - Number(y) : x.localeCompare(y);
        return descending ? -order : order;
      });
      rows.forEach(row => body.appendChild(row));
    };
    th.addEventListener("click", sort);
    th.addEventListener("keydown", event => { if (event.key === "Enter") sort(); });
  });
});
"""

#: (key, title, kind): the table's columns.
COLUMNS: list[tuple[str, str, str]] = [
    ("rank", "rank", "number"), ("source", "submission", "text"), ("model", "model", "text"),
    ("planner", "planner", "text"),
    ("prompt_suite", "prompt suite", "text"), ("settings", "settings", "text"),
    ("condition", "condition", "text"), ("verification", "verification", "text"),
    ("episodes", "episodes", "number"), ("sr", "SR", "number"), ("cs", "CS", "number"),
    *[(f"cs_{d}", f"CS_{d}", "number") for d in DIMENSIONS],
    ("pass_k", "pass^k", "number"), ("legal", "legal", "number"),
    ("tokens", "tokens/ep", "number"), ("dollars", "$/ep", "number"),
    ("pages", "episodes' pages", "text"),
]


def write_site(rows: Sequence[Row], out: Path, *, confidence: float = 0.95) -> Path:
    """Write the site into `out` (created); return its `index.html`."""
    out.mkdir(parents=True, exist_ok=True)
    env = jinja2.Environment(autoescape=True, undefined=jinja2.StrictUndefined)
    page = env.from_string(PAGE).render(
        columns=COLUMNS, rows=[{"badge": r.badge, "cells": _cells(r)} for r in rows],
        confidence=f"{confidence:.0%}")
    (out / "leaderboard.css").write_text(STYLE, encoding="utf-8")
    (out / "leaderboard.js").write_text(SCRIPT, encoding="utf-8")
    (out / "leaderboard.json").write_text(json.dumps([_record(r) for r in rows], indent=2),
                                          encoding="utf-8")
    index = out / "index.html"
    index.write_text(page, encoding="utf-8")
    return index


def _cells(row: Row) -> list[dict[str, Any]]:
    settings = ", ".join(row.settings) or "reference"
    return [
        _number(row.rank, str(row.rank) if row.rank else "–"),
        _text(row.source), _text(row.model), _text(row.planner), _text(row.prompt_suite),
        _text(settings), _text(row.condition),
        {**_text(row.badge if not row.settings else f"{row.badge} · labelled"),
         "badge": row.badge, "title": row.why or settings},
        _number(row.episodes, str(row.episodes)),
        _estimate(row.sr, percent=True), _estimate(row.cs),
        *[_estimate(row.cs_dims[d]) for d in DIMENSIONS],
        _number(row.pass_k[1] if row.pass_k else None,
                f"{row.pass_k[1]:.2f} (k={row.pass_k[0]})" if row.pass_k else "–"),
        _estimate(row.legal, percent=True),
        _number(row.tokens, f"{row.tokens:,.0f}"),
        _number(row.dollars, "–" if row.dollars is None else f"${row.dollars:.4f}"),
        {**_text("view"), "href": row.pages},
    ]


def _text(value: str) -> dict[str, Any]:
    return {"text": value, "sort": value}


def _number(value: float | None, text: str) -> dict[str, Any]:
    return {"text": text, "sort": "" if value is None else repr(float(value))}


def _estimate(estimate: Estimate, percent: bool = False) -> dict[str, Any]:
    if estimate.na:
        return _number(None, "–")
    scale, form = (100.0, "{:.1f}%") if percent else (1.0, "{:.2f}")
    text = form.format(estimate.value * scale)
    title = (f"[{form.format(estimate.lo * scale)}, {form.format(estimate.hi * scale)}] "
             f"n={estimate.n}")
    return {**_number(estimate.value, f"{text} [{form.format(estimate.lo * scale)}–"
                                       f"{form.format(estimate.hi * scale)}]"), "title": title}


def _record(row: Row) -> dict[str, Any]:
    record = asdict(row)
    record["rankable"] = row.rankable
    return record
