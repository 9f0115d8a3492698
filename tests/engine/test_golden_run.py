"""Behaviour unchanged (issue 27): the golden request records, field by field, what the golden
file holds (`tests/engine/golden_run.py` says what the request is and how to rewrite it)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from tests.engine.golden_run import GOLDEN, capture


def _differences(want: Any, got: Any, where: str = "") -> list[str]:
    """Where `got` differs from `want`, as JSON paths with both values."""
    if isinstance(want, dict) and isinstance(got, dict):
        out: list[str] = []
        for key in sorted(set(want) | set(got)):
            if key not in got or key not in want:
                out.append(f"{where}/{key}: {'missing' if key not in got else 'unexpected'}")
            else:
                out += _differences(want[key], got[key], f"{where}/{key}")
        return out
    if isinstance(want, list) and isinstance(got, list) and len(want) == len(got):
        return [d for i, (w, g) in enumerate(zip(want, got))
                for d in _differences(w, g, f"{where}[{i}]")]
    return [] if want == got else [f"{where}: want {want!r:.200}, got {got!r:.200}"]


def test_the_golden_request_records_what_it_always_did(tmp_path: Path) -> None:
    want = json.loads(GOLDEN.read_text(encoding="utf-8"))
    got = json.loads(json.dumps(capture(tmp_path)))  # tuples → lists, as in the file
    differences = _differences(want, got)
    assert not differences, f"{len(differences)} differences, first: " + "\n".join(
        differences[:20])
