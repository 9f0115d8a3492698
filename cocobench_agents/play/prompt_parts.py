"""The parts of a rendered prompt the play page shows on their own: the goal, its progress,
the teammates' messages, the recent actions, the state, and the menu's lines (the play page
labels its buttons with them, as the model reads them, with the agent named once above its
buttons: `agent_label`; and numbers the recent actions by the episode's steps:
`numbered_history`).

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
#: A menu line's text naming its agent: "agent_1: find a Fridge", which the centralized menu
#: follows with the agent again ("… [agent_1]").
AGENT_LABEL = re.compile(r"(?P<agent>[\w.-]+): (?P<text>.+?)(?: \[(?P=agent)\])?")
HISTORY_LINE = re.compile(r"\d+\. (.+)")


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


def agent_label(label: str) -> tuple[str | None, str]:
    """The agent a menu line names and the line without it (`agent_1: find a Fridge
    [agent_1]` → `agent_1`, `find a Fridge`); (None, `label`) when it names none."""
    found = AGENT_LABEL.fullmatch(label)
    return (found["agent"], found["text"]) if found else (None, label)


def numbered_history(history: str, landed: list[tuple[int, str]]) -> list[str] | None:
    """The recent-action lines of a prompt numbered by the episode's steps rather than by
    the window's 1…6: `landed` are the (step, call) of the seat's landed steps, oldest
    first. None when the lines are not those steps (no history yet, a suite of one's own)."""
    lines = [HISTORY_LINE.fullmatch(line) for line in history.splitlines()]
    if not lines or len(lines) > len(landed):
        return None
    numbered = []
    for line, (step, call) in zip(lines, landed[-len(lines):]):
        if line is None or not line[1].startswith(f"{call} -> "):
            return None
        numbered.append(f"step {step}: {line[1]}")
    return numbered
