"""Skill-call strings: `Skill(agent_i, arg1, arg2…)` (reference §4.1)."""

from __future__ import annotations

import re
from dataclasses import dataclass

_CALL = re.compile(r"^\s*([A-Za-z_][A-Za-z0-9_]*)\s*\((.*)\)\s*$", re.S)


@dataclass(frozen=True)
class SkillCall:
    """A parsed skill call; `args` excludes the agent."""

    skill: str
    agent: str
    args: tuple[str, ...] = ()

    def __str__(self) -> str:
        return f"{self.skill}({', '.join((self.agent, *self.args))})"


class CallSyntaxError(ValueError):
    """A string that is not a skill call."""


def parse_call(text: str) -> SkillCall:
    """Parse `Skill(agent_k, a, b)`; object ids contain no commas."""
    match = _CALL.match(text)
    if not match:
        raise CallSyntaxError(f"not a skill call: {text!r}")
    parts = [p.strip() for p in match.group(2).split(",")] if match.group(2).strip() else []
    if not parts:
        raise CallSyntaxError(f"skill call without an agent: {text!r}")
    return SkillCall(match.group(1), parts[0], tuple(parts[1:]))


def agent_index(agent: str) -> int:
    """AI2-THOR agentId of `agent_k` (k-1)."""
    match = re.fullmatch(r"agent_(\d+)", agent)
    if not match or int(match.group(1)) < 1:
        raise ValueError(f"invalid agent id {agent!r} (expected agent_1, agent_2, …)")
    return int(match.group(1)) - 1
