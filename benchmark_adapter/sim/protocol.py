"""The `Controller` protocol: the subset of AI2-THOR's native API the skill executor uses.

Every backend (embedded, real AI2-THOR) speaks it. Metadata follows AI2-THOR's per-agent
schema (`agent`, `objects`, `inventoryObjects`, `lastActionSuccess`, `errorMessage`,
`actionReturn`), as plain mappings: no backend object leaves its module.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, Protocol, runtime_checkable

Metadata = Mapping[str, Any]
"""One agent's metadata, in AI2-THOR's schema."""


@runtime_checkable
class Controller(Protocol):
    """A multi-agent household simulator."""

    agent_count: int

    def reset(self) -> Sequence[Metadata]:
        """Reload the scene (init actions are applied afterwards by the caller)."""
        ...

    def step(self, action: str, agentId: int | None = None, **kwargs: Any) -> Sequence[Metadata]:
        """Run one native action as agent `agentId`; return every agent's metadata after it."""
        ...

    def last_metadata(self) -> Sequence[Metadata]:
        """Every agent's metadata after the most recent action."""
        ...

    def frame(self, agent: int, width: int = 300, height: int = 300) -> bytes:
        """PNG of what agent `agent` currently sees."""
        ...

    def stop(self) -> None:
        """Release the backend's resources."""
        ...
