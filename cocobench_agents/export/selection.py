"""`--where`: which episodes an export keeps, chosen from their result lines.

A selector is a flag (``success``, ``failure``, ``legal``, ``illegal``) or a field test
(``condition=D1_blind``, ``model=greedy``, ``arm=…``, ``task_id=…``, ``cell=…``, ``dim=…``,
``family=…``); a field test may list values separated by commas (any of them matches). An
episode is kept when it passes every selector given.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import Any

from cocobench_agents.export.errors import ExportError

Line = Mapping[str, Any]

#: Flags: an episode's outcome, read from its result line (whose flags are 1/0 or true/false).
FLAGS: dict[str, Callable[[Line], bool]] = {
    "success": lambda line: line.get("task_success") == 1,
    "failure": lambda line: line.get("task_success") != 1,
    "legal": lambda line: line.get("legal_plan") == 1,
    "illegal": lambda line: line.get("legal_plan") != 1,
}
#: Field tests: the selector's name, and the result line's field it compares.
FIELDS = {"condition": "condition", "model": "model", "arm": "arm", "task_id": "task_id",
          "cell": "cell", "dim": "dim", "family": "family"}
#: Every selector, as `--help` and the errors name them.
SELECTORS = (*FLAGS, *(f"{name}=VALUE" for name in FIELDS))


@dataclass(frozen=True)
class Selector:
    """One `--where` term: its text, and the test it makes of a result line."""

    text: str
    test: Callable[[Line], bool]
    field: str | None = None  # the field a field test compares (for "no episode has …")


def parse_selector(text: str) -> Selector:
    """One `--where` value as a `Selector` (`ExportError` naming the known ones)."""
    name, has_value, value = (part.strip() for part in text.partition("="))
    if not has_value:
        if name in FLAGS:
            return Selector(text, FLAGS[name])
        if name in FIELDS:
            raise ExportError(f"--where {text!r}: {name} needs a value ({name}=VALUE)")
        raise ExportError(_unknown(text))
    if name in FLAGS:
        raise ExportError(f"--where {text!r}: {name} takes no value (write --where {name})")
    if name not in FIELDS:
        raise ExportError(_unknown(text))
    values = frozenset(v.strip() for v in value.split(",") if v.strip())
    if not values:
        raise ExportError(f"--where {text!r}: no value after '=' ({name}=VALUE[,VALUE…])")
    field = FIELDS[name]
    return Selector(text, lambda line: str(line.get(field) or "") in values, field)


def _unknown(text: str) -> str:
    return f"--where {text!r}: unknown selector; use one of: {', '.join(SELECTORS)}"


@dataclass(frozen=True)
class Selection:
    """Every `--where` of an export (none: every episode)."""

    selectors: tuple[Selector, ...] = ()

    @classmethod
    def parse(cls, texts: Iterable[str]) -> Selection:
        return cls(tuple(parse_selector(t) for t in texts))

    def keeps(self, line: Line) -> bool:
        return all(s.test(line) for s in self.selectors)

    def describe(self) -> str:
        """The selection in words, for the dataset card and the messages."""
        return " and ".join(s.text for s in self.selectors) or "every episode"

    def explain_empty(self, lines: Iterable[Line]) -> str:
        """Why nothing passed: the values the runs hold for each field tested."""
        lines = list(lines)
        notes = []
        for field in dict.fromkeys(s.field for s in self.selectors if s.field):
            present = sorted({str(line.get(field) or "") for line in lines} - {""})
            notes.append(f"{field}: {', '.join(present) or '(none recorded)'}")
        held = f" (the runs hold {'; '.join(notes)})" if notes else ""
        return f"no episode passes --where {self.describe()}{held}"
