"""Planner graph state: plain, serialisable data only.

The live `Episode` and the model clients reach nodes through the runtime context
(`context.py`), never through state.
"""

from __future__ import annotations

from typing import Annotated, Any

# typing_extensions' TypedDict: on Python < 3.12 pydantic (LangGraph's input JSON schema, as
# Studio shows it) refuses typing's.
from typing_extensions import TypedDict

from cocobench_agents.models.protocol import TEAM_SEAT

TEAM = TEAM_SEAT  # history key of the team-wide history (a centralized planner, the leader)


def collect(old: list[dict[str, Any]] | None, new: list[dict[str, Any]] | None
            ) -> list[dict[str, Any]]:
    """Reducer for a round's decisions: fan-out branches append; `None` clears."""
    if new is None:
        return []
    return [*(old or []), *new]


class PlannerState(TypedDict, total=False):
    """What a planner carries from step to step."""

    agents: list[str]  # the team, in config order
    round_index: int
    history: dict[str, list[str]]  # per agent (or TEAM): "call -> ok" / "call -> FAIL(…)"
    messages: list[dict[str, Any]]  # the broadcast board: {round, agent, text}
    pending: Annotated[list[dict[str, Any]], collect]  # this step's / round's decisions
    terminal_reason: str | None


def team_history(state: PlannerState) -> list[str]:
    """The team-wide history (centralized planner, leader), oldest first."""
    return (state.get("history") or {}).get(TEAM, [])
