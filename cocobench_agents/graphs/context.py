"""The runtime context of a planner graph: the live episode and the model clients."""

from __future__ import annotations

from dataclasses import dataclass, field

from cocobench_agents.graphs.model_calls import recording_clients
from cocobench_agents.models.protocol import TEAM_SEAT, ModelClient
from cocobench_agents.models.retry import RetryPolicy
from cocobench_agents.tools import EpisodeTools


@dataclass
class PlannerContext:
    """Everything a node may use besides state."""

    tools: EpisodeTools
    clients: dict[str, ModelClient]  # per agent; key TEAM_SEAT: the team's (or leader's) model
    budget: int | None  # landed steps allowed (None: unbounded)
    sample_index: int = 0
    # How decide retries transient model failures; the run-level options by default.
    retry_policy: RetryPolicy = field(default_factory=RetryPolicy)

    def __post_init__(self) -> None:
        # A call made with a client directly, not through `decide` or `ask`, is recorded too.
        self.clients = recording_clients(self.clients, self.tools)

    def client_for(self, agent: str | None) -> ModelClient:
        """The model that decides for `agent` (None: the team's planner)."""
        if agent is not None and agent in self.clients:
            return self.clients[agent]
        return self.clients[TEAM_SEAT]

    def budget_spent(self) -> bool:
        """Whether the step budget is used up."""
        return self.budget is not None and self.tools.step_index >= self.budget
