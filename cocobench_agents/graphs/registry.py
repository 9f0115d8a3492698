"""`PLANNERS`: the built-in coordination strategies by name, and what a planner is
(`PlannerSpec`, `PlannerError`). `lookup.py` resolves any planner reference (a built-in, an
installed plugin, `FILE.py:NAME`, `module:NAME`).

A new strategy lives in the researcher's own file or package, not here (`plugins.py`,
docs/planners.md).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from cocobench_agents.models.retry import RetryPolicy

if TYPE_CHECKING:
    from langgraph.graph import StateGraph


#: `PlannerSpec.loop` and `PlannerSpec.prompt` values.
LOOPS = ("step", "round", "led-round")
PROMPTS = ("team", "agent")


@dataclass(frozen=True)
class PlannerSpec:
    """A planner: how to build its graph and how a run gives it models. Your own strategy
    exports one (or just its build function) from a file or package (docs/planners.md)."""

    name: str  # set to the reference it is loaded by (a file's path, an entry point's name)
    code: str  # condition code in run folders and reports: C0, D0, D1, …
    build: Callable[[], StateGraph]
    decentralized: bool  # one model per agent (else one model for the team)
    uses_models: bool
    description: str
    # How this strategy retries transient model failures; None: the run-level options.
    retry_policy: RetryPolicy | None = None
    # How it asks its models, which the dry run's estimate reads (engine/estimate.py):
    # "step": one call per landed step (C0); "round": every agent once per round (D0, D1);
    # "led-round": a leader's call, then every agent's, per round (leader-worker); None: not
    # declared (the estimate assumes one call per agent per landed step, and says so).
    loop: str | None = None
    # Which prompt its model calls render: "team" (the centralized prompt: every agent's view
    # and menu) or "agent" (each agent's own); None: "agent" when decentralized, else "team".
    prompt: str | None = None
    broadcast: bool = False  # agents read and write the message board (`MSG:`), as in D1

    @property
    def prompt_kind(self) -> str:
        """The prompt its calls render: `prompt`, or what `decentralized` implies."""
        return self.prompt or ("agent" if self.decentralized else "team")


def lazy_builder(target: str, **kwargs: Any) -> Callable[[], StateGraph]:
    """A graph builder named ``module:function``, imported when a graph is first built (so
    the registry can be read without importing LangGraph)."""

    def build() -> StateGraph:
        module, _, name = target.partition(":")
        return getattr(importlib.import_module(module), name)(**kwargs)

    arguments = ", ".join(f"{k}={v!r}" for k, v in kwargs.items())
    build.target = f"{target}({arguments})" if arguments else target  # for listings
    return build


_GRAPHS = "cocobench_agents.graphs"
PLANNERS: dict[str, PlannerSpec] = {spec.name: spec for spec in (
    PlannerSpec("centralized", "C0", lazy_builder(f"{_GRAPHS}.centralized:build_centralized"),
                False, True,
                "one planner sees all views and moves one agent per step (paper C0)",
                loop="step", prompt="team"),
    PlannerSpec("decentralized", "D0",
                lazy_builder(f"{_GRAPHS}.decentralized:build_decentralized", broadcast=False),
                True, True, "one model per agent, simultaneous decisions, no messages (D0)",
                loop="round", prompt="agent"),
    PlannerSpec("decentralized-broadcast", "D1",
                lazy_builder(f"{_GRAPHS}.decentralized:build_decentralized", broadcast=True),
                True, True, "D0 plus a broadcast message board (D1)",
                loop="round", prompt="agent", broadcast=True),
    PlannerSpec("leader-worker", "LW", lazy_builder(f"{_GRAPHS}.leader_worker:build_leader_worker"),
                True, True,
                "a leader model instructs each robot every round; robots decide in parallel",
                loop="led-round", prompt="agent", broadcast=True),
    PlannerSpec("oracle", "OR", lazy_builder(f"{_GRAPHS}.oracle:build_oracle"), False, False,
                "the cell's privileged reference plan"),
)}
#: The paper's architectures (C0, D0, D1): the planners of the `all`, `image` and `blind`
#: condition shortcuts.
PAPER_PLANNERS = ("centralized", "decentralized", "decentralized-broadcast")


class PlannerError(ValueError):
    """A planner that cannot be used: unknown, failing to load, or failing its check."""


class UnknownPlanner(PlannerError):
    """A planner name that is neither built in nor registered by an installed package."""
