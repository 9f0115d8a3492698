"""Compact, deterministic JSON for shipped configs: 2-space indent, short containers on one line.

A list or object whose one-line form fits within `WIDTH` columns is written on one line
(skill lists, goal predicates, init actions), larger ones are broken up. Key order is kept.
The output depends only on the data, so regenerated files are byte-identical.
"""

from __future__ import annotations

import json
from typing import Any

WIDTH = 100
INDENT = 2


def dumps(data: Any) -> str:
    """The document text, ending with a newline."""
    return _format(data, 0, 0) + "\n"


def _format(value: Any, indent: int, column: int) -> str:
    flat = json.dumps(value)
    if not isinstance(value, (dict, list)) or not value or column + len(flat) <= WIDTH:
        return flat
    pad = " " * (indent + INDENT)
    if isinstance(value, list):
        lines = [pad + _format(v, indent + INDENT, len(pad)) for v in value]
        return "[\n" + ",\n".join(lines) + "\n" + " " * indent + "]"
    lines = []
    for key, item in value.items():
        head = f"{pad}{json.dumps(key)}: "
        lines.append(head + _format(item, indent + INDENT, len(head)))
    return "{\n" + ",\n".join(lines) + "\n" + " " * indent + "}"
