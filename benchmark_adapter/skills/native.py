"""Issuing native actions for one skill and reading the answers (reference §4.1)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from benchmark_adapter.sim.protocol import Controller, Metadata
from benchmark_adapter.skills.result import SkillResult


class NativeSession:
    """Native actions issued on behalf of one skill, recorded into its result's trace."""

    def __init__(self, controller: Controller, result: SkillResult, agent: int) -> None:
        self.controller, self.result, self.agent = controller, result, agent
        self.metadata: Sequence[Metadata] = controller.last_metadata()

    def act(self, action: str, **kwargs: Any) -> Metadata:
        """Run `action` as this agent; return the acting agent's metadata after it."""
        # Let go of the previous snapshot first: a backend may have to freeze (build) every
        # snapshot still held before it changes the world.
        self.metadata = ()
        self.metadata = self.controller.step(action, agentId=self.agent, **kwargs)
        own = self.metadata[self.agent]
        self.result.native_trace.append(
            {
                "action": {"action": action, "agentId": self.agent, **kwargs},
                "lastActionSuccess": bool(own["lastActionSuccess"]),
                "errorMessage": own["errorMessage"] or "",
            }
        )
        return own

    def finish(self, own: Metadata) -> SkillResult:
        """Take the skill's outcome from the acting agent's last native answer."""
        self.result.success = bool(own["lastActionSuccess"])
        self.result.errorMessage = "" if self.result.success else (own["errorMessage"] or "")
        return self.result

    @property
    def me(self) -> Metadata:
        """The acting agent's current metadata."""
        return self.metadata[self.agent]

    def object(self, object_id: str) -> Mapping[str, Any] | None:
        """An object as agent 0 sees it (precondition checks read agent 0, reference §10.9)."""
        return find_object(self.metadata[0], object_id)

    def held(self) -> Mapping[str, Any] | None:
        """The acting agent's held object (first inventory entry)."""
        inventory = self.me["inventoryObjects"]
        return inventory[0] if inventory else None

    def holder_of(self, object_id: str) -> int | None:
        """Index of the agent holding `object_id`, if any."""
        for i, md in enumerate(self.metadata):
            if any(o["objectId"] == object_id for o in md["inventoryObjects"]):
                return i
        return None


def find_object(metadata: Metadata, object_id: str) -> Mapping[str, Any] | None:
    """The object record with this id in one agent's metadata."""
    lookup = getattr(metadata, "find_object", None)  # the embedded backend's: no full build
    if lookup is not None:
        return lookup(object_id)
    for obj in metadata["objects"]:
        if obj["objectId"] == object_id:
            return obj
    return None
