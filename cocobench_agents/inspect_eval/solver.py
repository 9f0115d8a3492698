"""The solver: one episode through our runner and planner graph, its decisions made by
Inspect's model (the ``inspect`` transport, `models.inspect_client`).

The trajectory and the result line go into the sample's store (`TRAJECTORY`, `RESULT`):
`inspect view` shows them, the scorer scores the trajectory, `cocobench import-inspect`
writes them as a run folder. An episode whose model calls got no answer (Inspect gave up
after its retries) is an infrastructure failure, as in `cocobench run`: the sample ends in
an error (Inspect's ``--retry-on-error`` runs it again), never in a score.
"""

from __future__ import annotations

import dataclasses
import time
from typing import Any

from inspect_ai.model import ModelOutput, get_model
from inspect_ai.solver import Generate, Solver, TaskState, solver

from benchmark_adapter.metrics import EpisodeResult
from cocobench_agents.episode_runner import DEFAULT_MODEL_KEY, run_episode
from cocobench_agents.graphs import NO_MODEL, planner_spec
from cocobench_agents.graphs.node_errors import PlannerNodeError
from cocobench_agents.harness.episodes import PlannedEpisode
from cocobench_agents.models import ModelPool
from cocobench_agents.models.inspect_client import InspectLimitReached, role_model
from cocobench_agents.models.settings import ModelSettings
from cocobench_agents.runfolder.episode_key import EpisodeKey
from cocobench_agents.runfolder.infra import is_infra_failure

TRAJECTORY = "cocobench:trajectory"  # the store key of the episode's trajectory document
RESULT = "cocobench:result"  # … and of its result line


class EpisodeInfraError(RuntimeError):
    """The episode does not measure the model (a model call got no answer after Inspect's
    retries, a planner node or the simulator failed): Inspect records the sample's error."""


@solver
def cocobench_solver(planned: dict[str, PlannedEpisode], settings: ModelSettings) -> Solver:
    """Run the sample's episode (`planned` by sample id) with Inspect's model."""
    settings = settings.model_copy(update={"transport": "inspect"})

    async def solve(state: TaskState, generate: Generate) -> TaskState:
        episode = planned[str(state.sample_id)]
        key = _key(episode, state.epoch - 1)
        spec = dataclasses.replace(
            episode.spec, models=seat_models(episode), sample_index=key.epoch,
            episode_key=key.folder().removeprefix("episodes/"))
        started = time.perf_counter()
        try:
            document, result = await run_episode(spec, ModelPool(settings),
                                                 controller=spec.controller())
        except PlannerNodeError as exc:
            if isinstance(exc.__cause__, InspectLimitReached):  # scored as it stands
                limit = exc.__cause__.limit
                state.store.set(TRAJECTORY, limit_ended(exc.document, limit))
                raise limit from None  # Inspect ends the sample at its limit
            state.store.set(TRAJECTORY, exc.document)
            raise EpisodeInfraError(str(exc)) from None
        line = result_line(result, key, elapsed_s=time.perf_counter() - started)
        state.store.set(TRAJECTORY, document)
        state.store.set(RESULT, line)
        state.output = ModelOutput.from_content(key.model, _summary(line))
        state.completed = True
        if is_infra_failure(line):
            raise EpisodeInfraError(infra_message(document))
        return state

    return solve


#: The terminal reason of an episode an Inspect usage limit ended.
USAGE_LIMIT = "usage_limit"


def limit_ended(document: dict[str, Any], limit: Any) -> dict[str, Any]:
    """The trajectory of an episode Inspect's usage `limit` (`LimitExceededError`) ended: its
    stop decision says so (``usage_limit``, the limit's type and message), not that a planner
    node failed."""
    label = {"status": USAGE_LIMIT, "terminal_reason": USAGE_LIMIT,
             "limit": getattr(limit, "type", None), "error": str(limit)}
    decisions = list(document.get("planner_decisions") or [])
    if decisions and decisions[-1].get("status") == "planner_error":
        decisions[-1] = {**decisions[-1], **label}
    items = list(document.get("trajectory") or [])  # the stop item the scores read
    if items and items[-1].get("label") == "policy_stop" and \
            (items[-1].get("policy_decision") or {}).get("status") == "planner_error":
        items[-1] = {**items[-1], "policy_decision": {**items[-1]["policy_decision"], **label}}
    return {**document, "planner_decisions": decisions, "trajectory": items}


def seat_models(episode: PlannedEpisode) -> dict[str, str]:
    """The episode's model strings: Inspect's model for the team; for a decentralized
    planner, the model of the Inspect model role named after an agent, where there is one."""
    models = {DEFAULT_MODEL_KEY: _name(get_model())}
    if planner_spec(episode.spec.planner).decentralized:
        for agent in episode.spec.config.agent_ids:
            role = role_model(agent)
            if role is not None:
                models[agent] = _name(role)
    return models


def result_line(result: EpisodeResult, key: EpisodeKey, *, elapsed_s: float | None = None
                ) -> dict[str, Any]:
    """An episode's scored result as the result line `cocobench run` writes for `key` (with
    its wall time, as the run's report shows it, when known)."""
    line = {**result.model_copy(update={"condition": key.condition, "epoch": key.epoch})
            .model_dump(mode="json"), **key.as_dict()}
    if elapsed_s is not None:
        line["elapsed_s"] = round(elapsed_s, 3)
    return line


def _key(episode: PlannedEpisode, epoch: int) -> EpisodeKey:
    """The episode's key as `cocobench run` keys it: Inspect's model (the label of a planner
    that calls none, the oracle's, stays), Inspect's epoch counted from 0."""
    model = episode.key.model if episode.key.model == NO_MODEL else _name(get_model())
    return dataclasses.replace(episode.key, model=model, epoch=epoch)


def _name(model: Any) -> str:
    """An Inspect model as our model string (``openai/gpt-4o``)."""
    return str(model)


def infra_message(document: dict[str, Any]) -> str:
    """Why an episode's model calls got no answer (its first backend error)."""
    for decision in document.get("planner_decisions") or []:
        if decision.get("status") == "backend_error":
            return (f"a model call got no answer after Inspect's retries "
                    f"({decision.get('error_kind')}): {decision.get('error')}")
    return "a model call got no answer after Inspect's retries"


def _summary(line: dict[str, Any]) -> str:
    cs = line.get("construct_score")
    return (f"success={line.get('task_success')} construct_score="
            f"{'unscored' if cs is None else round(cs, 4)} steps={line.get('num_steps')} "
            f"terminal_reason={line.get('terminal_reason')}")
