"""`PLANNERS`: the built-in coordination strategies by name, and what a planner is
(`PlannerSpec`, `PlannerError`). `lookup.py` resolves any planner reference (a built-in, an
installed plugin, `FILE.py:NAME`, `module:NAME`).

A new strategy lives in the researcher's own file or package, not here (`plugins.py`,
docs/planners.md).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from cocobench_agents.models.protocol import TEAM_SEAT
from cocobench_agents.models.retry import RetryPolicy

if TYPE_CHECKING:
    from langgraph.graph import StateGraph


#: `PlannerSpec.loop` values: who decides in a decision round.
STEP, ROUND, LED_ROUND = "step", "round", "led-round"
LOOPS = (STEP, ROUND, LED_ROUND)
#: The seats a decision round asks: the team's planner, a leader, an agent. `PlannerSpec.prompt`
#: is one of the first and the last: the prompt its agents' (or its team's) decisions render.
LEADER_SEAT, AGENT_SEAT = "leader", "agent"
PROMPTS = (TEAM_SEAT, AGENT_SEAT)

#: The built-in planners the rest of the package names: the default of a run, and the
#: reference plan (the upper bound `--baselines` adds).
DEFAULT_PLANNER = "centralized"
ORACLE = "oracle"
#: The model label of the rows of a planner that calls no model (`uses_models=False`): a run
#: names no model for them, and no model by this name is ever called.
NO_MODEL = ORACLE


@dataclass(frozen=True)
class Seat:
    """One model call of a decision round: who decides (`role`), and for an agent, which."""

    role: str  # TEAM_SEAT, LEADER_SEAT or AGENT_SEAT
    agent: str | None = None


@dataclass(frozen=True)
class PlannerSpec:
    """A planner: how to build its graph and how a run gives it models, and the shape of its
    decisions, which the dry run, `cocobench prompts show` and the viewer read. Your own
    strategy exports one (or just its build function) from a file or package
    (docs/planners.md)."""

    name: str  # set to the reference it is loaded by (a file's path, an entry point's name)
    code: str  # condition code in run folders and reports: C0, D0, D1, …
    build: Callable[[], StateGraph]
    decentralized: bool  # one model per agent (else one model for the team)
    uses_models: bool  # False: it calls no model (the oracle); its rows' model is `NO_MODEL`
    description: str
    # How this strategy retries transient model failures; None: the run-level options.
    retry_policy: RetryPolicy | None = None
    # Who decides in a round, which the dry run counts calls by (`seats`, `most_calls`):
    # "step": one call per landed step (C0); "round": every agent once per round (D0, D1);
    # "led-round": a leader's call, then every agent's, per round (leader-worker); None: not
    # declared (the estimate assumes one call per agent per landed step, and says so).
    loop: str | None = None
    # Which prompt its model calls render: "team" (the centralized prompt: every agent's view
    # and menu) or "agent" (each agent's own); None: "agent" when decentralized, else "team".
    # A led round's leader renders the leader's prompt.
    prompt: str | None = None
    broadcast: bool = False  # agents read and write the message board (`MSG:`), as in D1
    # The most model calls one seat makes in a round (a step, for "step"): a strategy that
    # asks a robot again within a round declares how often (claim-board: 2).
    calls_per_seat: int = 1
    # Its own prompt templates (name → default text), which `ask` renders: part of the
    # prompt suite (a suite folder's NAME.txt replaces one; the suite's hash covers them).
    templates: Mapping[str, str] = field(default_factory=dict, hash=False)
    # Its round as plain async functions (`rounds.Rounds`), which `build`'s graph is built
    # from: an episode then awaits them in a plain loop, without LangGraph's per-superstep
    # cost. None (a strategy that gives only a graph): episodes run the graph. Typed Any, not
    # `Rounds`: rounds.py reaches node_errors, which reads this registry (an import cycle).
    rounds: Callable[[], Any] | None = None

    @property
    def prompt_kind(self) -> str:
        """The prompt its calls render: `prompt`, or what `decentralized` implies."""
        return self.prompt or (AGENT_SEAT if self.decentralized else TEAM_SEAT)

    @property
    def declares_loop(self) -> bool:
        """Whether its calls are counted from what it declares (else `loop_kind` is assumed
        and so is the bound of its calls)."""
        return self.loop is not None or not self.uses_models

    @property
    def loop_kind(self) -> str:
        """Its `loop`, or for a spec that declares none, what its prompt implies: the team's
        model asked as C0 asks it ("step"), or every agent as D0 asks them ("round")."""
        return self.loop or (ROUND if self.prompt_kind == AGENT_SEAT else STEP)

    def seats(self, agents: Sequence[str]) -> list[Seat]:
        """Who its first decision round asks, in the order it asks them (none when it calls
        no model): the team, or agent `agents[0]`, for a step loop; every agent for a round,
        after the leader for a led round."""
        if not self.uses_models:
            return []
        kind = self.loop_kind
        if kind == STEP:
            return [Seat(TEAM_SEAT)] if self.prompt_kind == TEAM_SEAT else \
                [Seat(AGENT_SEAT, agents[0])]
        every = [Seat(AGENT_SEAT, agent) for agent in agents]
        return [Seat(LEADER_SEAT), *every] if kind == LED_ROUND else every

    def seat_calls(self, agent_count: int, rounds: int) -> int:
        """The most calls one seat makes in an episode of at most `rounds` decision rounds
        (landed steps, for a step loop): `calls_per_seat` each, and for a spec that declares
        no loop, one per agent per step (the assumed bound)."""
        per_round = self.calls_per_seat
        if not self.declares_loop and self.loop_kind == STEP:
            per_round *= agent_count
        return rounds * per_round

    def seat_count(self, agent_count: int) -> int:
        """How many seats a decision round of a team of `agent_count` asks (`seats`)."""
        if not self.uses_models:
            return 0
        kind = self.loop_kind
        return 1 if kind == STEP else agent_count + (kind == LED_ROUND)

    def most_calls(self, agent_count: int, budget: int) -> int:
        """The most model calls of an episode of step budget `budget`: every seat of a round
        is asked (`seat_calls`), and a round lands at least one step or ends the episode, so
        there are at most `budget` rounds. Retries are not counted."""
        return self.seat_count(agent_count) * self.seat_calls(agent_count, budget)


def lazy_builder(target: str, **kwargs: Any) -> Callable[[], Any]:
    """A graph (or `Rounds`) builder named ``module:function``, imported when first called
    (so the registry can be read without importing LangGraph)."""

    def build() -> Any:
        module, _, name = target.partition(":")
        return getattr(importlib.import_module(module), name)(**kwargs)

    arguments = ", ".join(f"{k}={v!r}" for k, v in kwargs.items())
    build.target = f"{target}({arguments})" if arguments else target  # for listings
    return build


_GRAPHS = "cocobench_agents.graphs"
PLANNERS: dict[str, PlannerSpec] = {spec.name: spec for spec in (
    PlannerSpec(DEFAULT_PLANNER, "C0", lazy_builder(f"{_GRAPHS}.centralized:build_centralized"),
                False, True,
                "one planner sees all views and moves one agent per step (paper C0)",
                loop="step", prompt="team",
                rounds=lazy_builder(f"{_GRAPHS}.centralized:centralized_rounds")),
    PlannerSpec("decentralized", "D0",
                lazy_builder(f"{_GRAPHS}.decentralized:build_decentralized", broadcast=False),
                True, True, "one model per agent, simultaneous decisions, no messages (D0)",
                loop="round", prompt="agent",
                rounds=lazy_builder(f"{_GRAPHS}.decentralized:decentralized_rounds",
                                    broadcast=False)),
    PlannerSpec("decentralized-broadcast", "D1",
                lazy_builder(f"{_GRAPHS}.decentralized:build_decentralized", broadcast=True),
                True, True, "D0 plus a broadcast message board (D1)",
                loop="round", prompt="agent", broadcast=True,
                rounds=lazy_builder(f"{_GRAPHS}.decentralized:decentralized_rounds",
                                    broadcast=True)),
    PlannerSpec("leader-worker", "LW", lazy_builder(f"{_GRAPHS}.leader_worker:build_leader_worker"),
                True, True,
                "a leader model instructs each robot every round; robots decide in parallel",
                loop="led-round", prompt="agent", broadcast=True,
                rounds=lazy_builder(f"{_GRAPHS}.leader_worker:leader_worker_rounds")),
    PlannerSpec(ORACLE, "OR", lazy_builder(f"{_GRAPHS}.oracle:build_oracle"), False, False,
                "the cell's privileged reference plan",
                rounds=lazy_builder(f"{_GRAPHS}.oracle:oracle_rounds")),
)}
#: The paper's architectures (C0, D0, D1): the planners of the `all`, `image` and `blind`
#: condition shortcuts.
PAPER_PLANNERS = ("centralized", "decentralized", "decentralized-broadcast")


class PlannerError(ValueError):
    """A planner that cannot be used: unknown, failing to load, or failing its check."""


class UnknownPlanner(PlannerError):
    """A planner name that is neither built in nor registered by an installed package."""
