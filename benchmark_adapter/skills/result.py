"""`SkillResult`: what one high-level skill did, with the native actions it issued."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any


@dataclass
class SkillResult:
    """Outcome of one skill: one step, however many native actions it took."""

    skill: str
    agent: str
    args: dict[str, Any]
    success: bool = False
    errorMessage: str = ""
    native_trace: list[dict[str, Any]] = field(default_factory=list)

    def fail(self, message: str) -> SkillResult:
        """Mark the result failed with `message` and return it."""
        self.success, self.errorMessage = False, message
        return self

    def to_dict(self) -> dict[str, Any]:
        """The reference's `skill_result` record."""
        return {
            "skill": self.skill,
            "agent": self.agent,
            "args": dict(self.args),
            "success": self.success,
            "errorMessage": self.errorMessage,
            "native_trace": list(self.native_trace),
        }
