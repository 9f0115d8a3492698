"""The parts of a rendered prompt the play page shows on their own: the goal, its progress,
the teammates' messages, the recent actions, the state, and the menu's lines (the play page
labels its buttons with them, as the model reads them).

The shipped suites write each part as a heading line followed by lines indented by two
spaces (`prompts/render.py`); a suite of one's own may word them otherwise, and then its
parts are simply not found: the page always shows the full prompt too.
"""

from __future__ import annotations

import re


def _heading(words: str) -> re.Pattern[str]:
    """A heading line: its words, an optional remark in parentheses, a colon, and perhaps the
    part's first line ("GOAL: Put the apple in the fridge", "YOUR STATE: holding=…")."""
    return re.compile(rf"{words}(?: \([^)]*\))?:(.*)")


#: Part name → the heading that opens it.
HEADINGS = {
    "goal": _heading("GOAL"),
    "progress": _heading("GOAL PROGRESS"),
    "messages": _heading("TEAMMATE MESSAGES"),
    "history": _heading("(?:YOUR )?RECENT ACTIONS"),
    "state": _heading("(?:YOUR|AGENT) STATE"),
    "menu": _heading("(?:YOUR )?ACTION MENU"),
}
MENU_LINE = re.compile(r"(\d+): (.+)")


def prompt_parts(prompt: str) -> dict[str, str]:
    """Each part found in `prompt`, by name, as its text without the heading."""
    lines = prompt.splitlines()
    parts: dict[str, str] = {}
    for index, line in enumerate(lines):
        for name, heading in HEADINGS.items():
            found = heading.fullmatch(line.rstrip())
            if found and name not in parts:
                body = [found.group(1).strip()] if found.group(1).strip() else []
                body += _indented_lines_after(lines, index)
                parts[name] = "\n".join(body)
    return parts


def _indented_lines_after(lines: list[str], index: int) -> list[str]:
    body = []
    for line in lines[index + 1:]:
        if not line.startswith(" ") or not line.strip():
            break
        body.append(line[2:] if line.startswith("  ") else line.lstrip())
    return body


def menu_labels(parts: dict[str, str]) -> dict[int, str]:
    """The menu's lines by action id (`13: agent_1: pick up the CellPhone` → 13 →
    `agent_1: pick up the CellPhone`)."""
    found = (MENU_LINE.fullmatch(line) for line in parts.get("menu", "").splitlines())
    return {int(m.group(1)): m.group(2) for m in found if m}
