"""The templates a prompt suite consists of, and the `{fields}` each may use.

Every template is a Python format string (`{field}`; `{{` and `}}` for literal braces). The
renderers (render.py, hints.py) fill exactly these fields, so a suite is checked against this
table when it loads: a typo in a field name is reported then, not in the middle of a run.
"""

from __future__ import annotations

import re
import string

from benchmark_adapter.vocabulary import OBSERVATION_MODES

# Fields of the prompts that see the whole team (centralized planner, leader).
_TEAM = frozenset({"n", "agents", "view", "goal", "progress_section", "hint", "menu",
                   "history_section", "state"})



def view_template(obs_mode: str, prompt: str) -> str:
    """The template saying what the model sees under `obs_mode` in a `prompt`
    (``centralized`` or ``distributed``): each observation mode has its own pair."""
    return f"view_{obs_mode}_{prompt}"


TEMPLATE_FIELDS: dict[str, frozenset[str]] = {
    "centralized": _TEAM,
    "leader": _TEAM | {"reply_format"},
    "distributed": frozenset({"me", "n", "agents", "view", "goal", "progress_section", "hint",
                              "comm", "msg_hint", "menu", "history_section", "inv"}),
    **{view_template(mode, "centralized"): frozenset({"agents"}) for mode in OBSERVATION_MODES},
    **{view_template(mode, "distributed"): frozenset() for mode in OBSERVATION_MODES},
    "progress_section": frozenset({"goal_progress"}),
    "history_section_centralized": frozenset({"history"}),
    "history_section_distributed": frozenset({"history"}),
    "state_centralized": frozenset({"agent_lines"}),
    "comm_block": frozenset({"board"}),
    "msg_hint": frozenset(),
    "hint_resource": frozenset(),
    "hint_relay": frozenset({"buffer", "producer", "consumer", "targets"}),
}

#: The fields `ask` (graphs) fills in a planner's own template, besides those the strategy gives:
#: the deciding agent's view (`me`, `inv`), or the team's (`state`) when it asks for the team;
#: `menu` lists the ask's choices. The section fields follow the suite's variants.
ASK_FIELDS = frozenset({"me", "n", "agents", "view", "goal", "progress_section", "hint",
                        "history_section", "inv", "state", "menu"})
#: A planner's own template's name: a file name of a suite folder (`NAME.txt`).
OWN_TEMPLATE_NAME = re.compile(r"[a-z][a-z0-9_]{0,63}")

# Sample values for the trial rendering at load time (`n` is the one number).
_SAMPLE = {"n": 2}


def own_template_fields(default: str) -> frozenset[str]:
    """The fields a planner's own template may use: those `ask` fills, and those its
    default text uses (which the strategy gives)."""
    return ASK_FIELDS | field_names(default)


def field_problem(key: str, text: str, allowed: frozenset[str] | None = None) -> str | None:
    """What is wrong with template `key`'s text as a format string, or None; `allowed`: its
    fields (default: the suite template's)."""
    allowed = TEMPLATE_FIELDS[key] if allowed is None else allowed
    try:
        used = field_names(text)
    except ValueError as exc:
        return f"{exc} (write {{{{ or }}}} for a literal brace)"
    unknown = sorted(used - allowed)
    if unknown:
        known = ", ".join(sorted(allowed)) or "none"
        # repr for a name holding a newline or other control character: the error is one line
        name = unknown[0] if unknown[0].isprintable() else repr(unknown[0])
        return f"unknown field {{{name}}} (fields of this template: {known})"
    try:  # what parsing accepts but formatting rejects: `{n:q}`, `{goal!z}`
        text.format(**{name: _SAMPLE.get(name, "x") for name in allowed})
    except (ValueError, TypeError) as exc:
        return f"cannot be formatted: {exc}"
    return None


def field_names(text: str) -> frozenset[str]:
    """The field names `text` uses, including those nested in format specs (a `ValueError`
    for a malformed format string)."""
    names: set[str] = set()
    for _, name, spec, _ in string.Formatter().parse(text):
        if name is not None:
            names.add(name)
        if spec:
            names |= field_names(spec)
    return frozenset(names)
