"""Tables for the terminal, drawn by rich (plain text, no colour, when not on a terminal)."""

from __future__ import annotations

import io
import sys
from collections.abc import Sequence

from rich import box
from rich.console import Console
from rich.table import Table

_UNBOUNDED = 100_000  # off a terminal a table keeps its natural width: lines never wrap


def table(headers: Sequence[str], rows: Sequence[Sequence[object]], *,
          caption: str | None = None) -> str:
    """Left-aligned columns under a ruled header, as text for `click.echo`."""
    grid = Table(*headers, box=box.SIMPLE_HEAD, caption=caption, caption_justify="left",
                 header_style="bold", show_edge=False, pad_edge=False)
    for row in rows:
        grid.add_row(*(_text(v) for v in row))
    terminal = sys.stdout.isatty()
    buffer = io.StringIO()
    console = Console(file=buffer, force_terminal=terminal, no_color=not terminal,
                      width=None if terminal else _UNBOUNDED, highlight=False)
    console.print(grid)
    return "\n".join(line.rstrip() for line in buffer.getvalue().strip("\n").splitlines())


def _text(value: object) -> str:
    if value is None:
        return "-"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        return f"{value:.2f}"
    return str(value)
