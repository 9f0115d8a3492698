"""High-level skills → native actions, one implementation for every backend."""

from benchmark_adapter.skills.calls import CallSyntaxError, SkillCall, agent_index, parse_call
from benchmark_adapter.skills.executor import SKILLS, SkillExecutor
from benchmark_adapter.skills.result import SkillResult

__all__ = [
    "SKILLS",
    "CallSyntaxError",
    "SkillCall",
    "SkillExecutor",
    "SkillResult",
    "agent_index",
    "parse_call",
]
