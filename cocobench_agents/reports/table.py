"""The small table object every report table is: typed columns, rows of cells."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

#: Column kinds and how their values are shown (Markdown decimals, CSV decimals, scale).
KINDS: dict[str, tuple[int, int, float]] = {
    "pct": (1, 4, 100.0),  # a proportion shown in percent
    "score": (2, 4, 1.0),  # a 0-1 score (construct scores, correlations)
    "num": (1, 4, 1.0),  # seconds, steps, calls
    "tokens": (0, 2, 1.0),
    "usd": (4, 6, 1.0),
    "p": (4, 6, 1.0),  # a p-value
}


@dataclass(frozen=True)
class Column:
    """One column. `key` names it in CSV (an estimate column expands to `key`, `key_lo`,
    `key_hi`, `key_n`); `header` names it in Markdown. `kind` is `text`, `int` or one of
    KINDS. `show_n` appends the estimate's n in Markdown. A KINDS column holds Estimates,
    unless `estimate` is False (plain numbers, e.g. totals). `markdown` False: CSV only."""

    key: str
    header: str
    kind: str = "text"
    show_n: bool = False
    estimate: bool = True
    markdown: bool = True

    @property
    def has_ci(self) -> bool:
        return self.kind in KINDS and self.estimate


@dataclass
class Table:
    """A report table: what `render` writes as Markdown and CSV and `plots` draws."""

    name: str  # file stem
    title: str
    caption: str
    columns: list[Column]
    rows: list[list[Any]] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)  # shown above the table

    def records(self) -> list[dict[str, Any]]:
        """Rows as {column key: cell}."""
        keys = [c.key for c in self.columns]
        return [dict(zip(keys, row)) for row in self.rows]

    def find(self, **match: Any) -> dict[str, Any] | None:
        """The first row whose cells equal `match`."""
        for record in self.records():
            if all(record.get(k) == v for k, v in match.items()):
                return record
        return None
