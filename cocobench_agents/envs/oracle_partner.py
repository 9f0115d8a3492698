"""The `oracle` partner: seats played by the instance's reference plan (the oracle planner's
plan), as far as the learner lets it. The plan is the team's, one call after another: a
partner seat plays the plan's next call when it is its own and on its menu, and waits (DONE)
otherwise; a call counts as done once it has landed, whoever landed it, so a learner who
plays a step of the plan moves the plan on."""

from __future__ import annotations

from collections.abc import Iterator

from benchmark_adapter.episode import Episode
from benchmark_adapter.oracles import oracle_plan
from benchmark_adapter.skills.calls import CallSyntaxError, parse_call
from cocobench_agents.graphs import ORACLE
from cocobench_agents.models.protocol import ModelReply, ModelRequest


class OraclePlan:
    """The reference plan of one episode and where the team stands in it."""

    def __init__(self, episode: Episode) -> None:
        self.episode = episode
        self._plan: Iterator[str] = oracle_plan(episode.config)
        self._seen = 0  # trajectory items already checked for the current call
        self.current: str | None = next(self._plan, None)

    def next_call(self) -> str | None:
        """The plan's next call not yet landed (None once the plan is through)."""
        items = self.episode.items
        for item in items[self._seen:]:
            if "skill_result" in item and item["label"] == self.current:
                self.current = next(self._plan, None)
        self._seen = len(items)
        return self.current


class OracleClient:
    """A seat's client that answers from the shared `OraclePlan`."""

    accepts_images = False

    def __init__(self, plan: OraclePlan) -> None:
        self.name, self.plan = ORACLE, plan

    async def complete(self, request: ModelRequest) -> ModelReply:
        call = self.plan.next_call()
        if request.agent is None and not request.menu:  # the leader: name the next step
            owner = _agent_of(call)
            return ModelReply(text=f"{owner}: {call}" if owner else "")
        entry = next((o for o in request.menu if o.call == call), None)
        return ModelReply(text=f"ACTION: {entry.action_id}" if entry else "ACTION: DONE")


def _agent_of(call: str | None) -> str | None:
    """`PickUp(agent_1, Apple|…)` → `agent_1` (None once the plan is through)."""
    try:
        return parse_call(call).agent if call is not None else None
    except CallSyntaxError:
        return None
