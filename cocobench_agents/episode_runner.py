"""Running one episode: a task config, a planner graph, models → trajectory and result."""

from __future__ import annotations

import uuid
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

from benchmark_adapter.episode import Episode
from benchmark_adapter.metrics import EpisodeResult
from benchmark_adapter.sim.protocol import Controller
from benchmark_adapter.tasks import TaskConfig
from benchmark_adapter.tasks.checks import MAX_STEP_BUDGET
from benchmark_adapter.vocabulary import DEFAULT_BACKEND, EMBEDDED, IMAGE
from cocobench_agents.graphs import (
    DEFAULT_PLANNER,
    PlannerContext,
    compiled_graph,
    planner_rounds,
    planner_spec,
)
from cocobench_agents.graphs.node_errors import (
    NodeFailure,
    PlannerNodeError,
    is_strategy_code,
    node_failure,
    run_to_end,
)
from cocobench_agents.models.human import HUMAN, HumanTurn
from cocobench_agents.models.protocol import TEAM_SEAT, ModelClient
from cocobench_agents.models.retry import RetryPolicy
from cocobench_agents.prompts import DEFAULT_SUITE, load_prompt_suite
from cocobench_agents.tools import EpisodeTools, stop_decision

DEFAULT_MODEL_KEY = "*"


@dataclass(frozen=True)
class EpisodeSpec:
    """What to run: one instance under one condition."""

    config: TaskConfig
    planner: str = DEFAULT_PLANNER
    models: dict[str, str] = field(default_factory=lambda: {DEFAULT_MODEL_KEY: "greedy"})
    obs_mode: str = IMAGE
    prompt_suite: str = DEFAULT_SUITE
    backend: str = DEFAULT_BACKEND
    max_steps: int | None = None  # overrides difficulty.step_budget
    stable_ids: bool = False
    sample_index: int = 0
    episode_key: str = ""  # names the episode to stateful clients (random streams, replay)

    @property
    def episode(self) -> str:
        """The episode's name for model clients: its run key, else the task id."""
        return self.episode_key or self.config.task_id

    @property
    def budget(self) -> int:
        """Landed steps allowed: `max_steps` if given, else the config's step budget; a
        config built in Python without one gets the largest budget a loaded config may have
        (the episode then ends on the budget, never on LangGraph's recursion limit)."""
        return self.max_steps or self.config.budget or MAX_STEP_BUDGET

    def controller(self) -> Controller | None:
        """A simulator for `backend` (None for the embedded one: the Episode builds it)."""
        if self.backend == EMBEDDED:
            return None
        from benchmark_adapter.sim.backends import make_controller

        return make_controller(self.config, self.backend)

    def model_for(self, agent: str | None) -> str:
        """The model string deciding for `agent` (None: the team's model)."""
        return self.models.get(agent or DEFAULT_MODEL_KEY) or self.models[DEFAULT_MODEL_KEY]

    def identifiers(self) -> dict[str, Any]:
        """What the result records about the run condition."""
        models: dict[str, str] | str = self.model_for(None)
        if any(k != DEFAULT_MODEL_KEY for k in self.models):
            models = {a: self.model_for(a) for a in self.config.agent_ids}
        return {"backend": self.backend, "models": models, "planner": self.planner,
                "obs_mode": self.obs_mode, "prompt_suite": self.prompt_suite}


class ClientFactory(Protocol):
    """Makes the model clients of one episode (see `models.ModelPool`)."""

    def client(self, spec: str, *, episode: str, agent: str | None) -> ModelClient: ...

    def release(self, episode: str) -> None: ...


def seat_models(spec: EpisodeSpec) -> dict[str, str]:
    """The model of each client the episode makes: the team's (`TEAM_SEAT`) and, for decentralized
    planners, each agent's; none for a planner that uses no model."""
    planner = planner_spec(spec.planner)
    if not planner.uses_models:
        return {}
    seats = {TEAM_SEAT: spec.model_for(None)}
    if planner.decentralized:
        seats.update({agent: spec.model_for(agent) for agent in spec.config.agent_ids})
    return seats


def has_human_seat(spec: EpisodeSpec) -> bool:
    """Whether a person decides for some seat of the episode."""
    return HUMAN in seat_models(spec).values()


def make_clients(spec: EpisodeSpec, pool: ClientFactory) -> dict[str, ModelClient]:
    """The team's client (`TEAM_SEAT`) and, for decentralized planners, one per agent."""
    return {seat: pool.client(model, episode=spec.episode,
                              agent=None if seat == TEAM_SEAT else seat)
            for seat, model in seat_models(spec).items()}


async def run_episode(spec: EpisodeSpec, pool: ClientFactory, *,
                      controller: Controller | None = None,
                      trajectory_path: str | Path | None = None,
                      on_step: Callable[[dict[str, Any]], None] | None = None,
                      ) -> tuple[dict[str, Any], EpisodeResult]:
    """Run one episode to its end; write its trajectory when a path is given. `on_step` is
    called with each landed step's trajectory item. A planner node that raises ends the
    episode with `PlannerNodeError` (`play_episode`)."""
    tools = episode_tools(spec, Episode(spec.config, controller))
    tools.on_step = on_step
    try:
        return await play_episode(spec, planner_context(spec, tools, make_clients(spec, pool),
                                                        pool), trajectory_path)
    finally:
        pool.release(spec.episode)


def episode_tools(spec: EpisodeSpec, episode: Episode) -> EpisodeTools:
    """The harness's tools over `episode`, with the prompts and observation mode of `spec`."""
    suite = load_prompt_suite(spec.prompt_suite, planner_spec(spec.planner).templates)
    return EpisodeTools(episode, suite, obs_mode=spec.obs_mode, stable_ids=spec.stable_ids)


def planner_context(spec: EpisodeSpec, tools: EpisodeTools, clients: dict[str, ModelClient],
                    pool: ClientFactory) -> PlannerContext:
    """What the planner's nodes of an episode of `spec` use besides state: `tools`, the
    seats' `clients`, the step budget and the retry policy (the planner's, else the run's)."""
    return PlannerContext(tools=tools, clients=clients, budget=spec.budget,
                          sample_index=spec.sample_index,
                          retry_policy=episode_retry_policy(spec, pool))


def episode_retry_policy(spec: EpisodeSpec, pool: ClientFactory) -> RetryPolicy:
    """How the episode's model calls are retried: the planner's policy, else the run's."""
    return planner_spec(spec.planner).retry_policy or run_retry_policy(pool)


async def play_episode(spec: EpisodeSpec, context: PlannerContext,
                       trajectory_path: str | Path | None = None
                       ) -> tuple[dict[str, Any], EpisodeResult]:
    """Play the planner's graph over `context` from the episode's start to its end; the
    trajectory (written when a path is given) and the result. `cocobench run` and the
    training environments (`cocobench_agents.envs`, whose learners' clients wait for their
    actions) both play an episode here. A planner node that raises ends the episode with
    `PlannerNodeError`, which names the node, file, line and last frames and carries the
    trajectory up to there (written to the path too)."""
    tools = context.tools
    tools.start()
    try:
        await _invoke(spec, context)
    except HumanTurn:  # not a failure: a person's turn pauses the episode
        raise
    except Exception as exc:
        failure = node_failure(exc)
        if failure is None:  # not the planner's doing (the simulator)
            raise
        raise PlannerNodeError(failure, _stopped(tools, failure, spec, trajectory_path)
                               ) from exc
    return tools.finish(trajectory_path, **spec.identifiers())


def _stopped(tools: EpisodeTools, failure: NodeFailure, spec: EpisodeSpec,
             path: str | Path | None) -> dict[str, Any]:
    """The trajectory of an episode a node's exception ended: up to that point, then a stop
    decision that says which node raised what, where."""
    stop = stop_decision(policy="harness", model=None, agent=None,
                         step_index=tools.step_index, status="planner_error")
    tools.stop({**stop, **failure.record()})
    document, _ = tools.finish(path, **spec.identifiers())
    return document


def run_retry_policy(pool: ClientFactory) -> RetryPolicy:
    """The run-level retry policy: the pool's settings when it has them."""
    settings = getattr(pool, "settings", None)
    return RetryPolicy.from_settings(settings) if settings is not None else RetryPolicy()


def initial_state(spec: EpisodeSpec) -> dict[str, Any]:
    """The planner graph's input: the team, the first round, nothing landed or posted."""
    return {"agents": spec.config.agent_ids, "round_index": 1, "history": {}, "messages": [],
            "terminal_reason": None}


async def _invoke(spec: EpisodeSpec, context: PlannerContext) -> None:
    """Play the planner: its declared rounds awaited directly (`rounds.play_rounds`), else
    its graph through LangGraph. Either way a planner that never ends raises `EndlessLoop`,
    naming its last nodes, after as many supersteps as LangGraph's recursion limit allows
    (each landed step takes a few)."""
    limit = 6 * spec.budget + 50
    rounds = planner_rounds(spec.planner)
    if rounds is not None:
        from cocobench_agents.graphs.rounds import play_rounds

        await play_rounds(rounds, initial_state(spec), context, limit=limit,
                          checked=is_strategy_code(planner_spec(spec.planner).name))
        return
    await run_to_end(
        compiled_graph(spec.planner), initial_state(spec), context=context,
        # A fresh thread per episode.
        config={"recursion_limit": limit, "configurable": {"thread_id": uuid.uuid4().hex}})
