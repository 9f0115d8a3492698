"""The solver: one episode through our runner and planner graph, its decisions made by
Inspect's model (the ``inspect`` transport, `models.inspect_client`).

The trajectory and the result line go into the sample's store (`TRAJECTORY`, `RESULT`):
`inspect view` shows them, the scorer scores the trajectory, `cocobench import-inspect`
writes them as a run folder. An episode whose model calls got no answer (Inspect gave up
after its retries) is an infrastructure failure, as in `cocobench run`: the sample ends in
an error (Inspect's ``--retry-on-error`` runs it again), never in a score. An episode the
planner's own code ended (`PlannerNodeError`) is the strategy's failure: scored as a failed
episode, with the scorer's `planner_error` set, never retried.
"""

from __future__ import annotations

import dataclasses
import time
from typing import Any

from inspect_ai.model import (
    ChatMessage,
    ChatMessageAssistant,
    ChatMessageUser,
    ContentText,
    ModelOutput,
    get_model,
)
from inspect_ai.solver import Generate, Solver, TaskState, solver

from benchmark_adapter.metrics import EpisodeResult, unrun_result
from benchmark_adapter.trajectory import PROMPTS_FIELD
from benchmark_adapter.vocabulary import IMAGE
from cocobench_agents.episode_runner import DEFAULT_MODEL_KEY, run_episode
from cocobench_agents.graphs import NO_MODEL, planner_spec
from cocobench_agents.graphs.node_errors import PlannerNodeError, is_strategy_code
from cocobench_agents.harness.episodes import PlannedEpisode
from cocobench_agents.models import ModelPool
from cocobench_agents.models.inspect_client import InspectLimitReached, role_model
from cocobench_agents.models.settings import ModelSettings
from cocobench_agents.runfolder.episode_key import EpisodeKey
from cocobench_agents.runfolder.infra import is_infra_failure
from cocobench_agents.runfolder.result_line import planner_error_line

TRAJECTORY = "cocobench:trajectory"  # the store key of the episode's trajectory document
RESULT = "cocobench:result"  # … and of its result line


class EpisodeInfraError(RuntimeError):
    """The episode does not measure the model (a model call got no answer after Inspect's
    retries, a built-in planner's node or the simulator failed): Inspect records the
    sample's error."""


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
        frames = sends_frames(episode)
        try:
            document, result = await run_episode(spec, ModelPool(settings),
                                                 controller=spec.controller())
        except PlannerNodeError as exc:
            if isinstance(exc.__cause__, InspectLimitReached):  # scored as it stands
                limit = exc.__cause__.limit
                _keep(state, limit_ended(exc.document, limit), frames)
                raise limit from None  # Inspect ends the sample at its limit
            _keep(state, exc.document, frames)
            if not is_strategy_code(spec.planner):  # a built-in planner's: ours
                raise EpisodeInfraError(str(exc)) from None
            # The strategy's own failure: scored as a failed episode (the scorer's
            # `planner_error`), never a sample error that Inspect would retry.
            line = planner_line(episode, key, str(exc), time.perf_counter() - started)
            state.store.set(RESULT, line)
            state.output = ModelOutput.from_content(key.model, line["planner_error"])
            state.completed = True
            return state
        line = result_line(result, key, elapsed_s=time.perf_counter() - started)
        _keep(state, document, frames)
        state.store.set(RESULT, line)
        state.output = ModelOutput.from_content(key.model, _summary(line))
        state.completed = True
        if is_infra_failure(line):
            raise EpisodeInfraError(infra_message(document))
        return state

    return solve


def _keep(state: TaskState, document: dict[str, Any], frames: bool) -> None:
    """Keep the episode's trajectory in the sample's store and its model calls as the
    sample's messages (what `inspect view` shows as the conversation)."""
    state.store.set(TRAJECTORY, document)
    state.messages = conversation(document, frames=frames)


def sends_frames(episode: PlannedEpisode) -> bool:
    """Whether each of the episode's model calls sent a frame with its prompt (an image
    condition of a planner that calls a model: Inspect's models read images)."""
    return episode.spec.obs_mode == IMAGE and planner_spec(episode.spec.planner).uses_models


def conversation(document: dict[str, Any], *, frames: bool = False) -> list[ChatMessage]:
    """An episode's model calls as chat messages, in the order they were decided: each
    decision's prompt as a user message, the model's reply (where it gave one) as an
    assistant message, both naming the deciding agent in their metadata (None: the team).

    Each call is a conversation of its own (a prompt holds the history the model is shown),
    so the messages are the calls one after the other, not one growing chat. A frame sent
    with a prompt (`frames`) is a one-line text part saying so: the frames are the model
    events' in the transcript, and a copy here would add an image per decision to the log."""
    prompts = document.get(PROMPTS_FIELD) or {}
    messages: list[ChatMessage] = []
    for decision in document.get("planner_decisions") or []:
        prompt = prompts.get(decision.get("prompt_hash"))
        if prompt is None:  # a stop without a model call (an empty menu, the step budget)
            continue
        agent = decision.get("agent")
        about = {"agent": agent, "step_index": decision.get("step_index"),
                 "status": decision.get("status")}
        messages.append(ChatMessageUser(
            content=[ContentText(text=prompt), ContentText(text=frame_note(agent))]
            if frames else prompt, metadata=about))
        reply = decision.get("raw_output")
        if reply is not None:
            messages.append(ChatMessageAssistant(content=reply, model=decision.get("model"),
                                                 metadata=about))
    return messages


def frame_note(agent: str | None) -> str:
    """The text that stands for the frame a decision of `agent` sent (None: the team's)."""
    view = "the team's merged view" if agent is None else f"{agent}'s view"
    return (f"[image: {view}, sent as a PNG frame; not kept in the sample's messages, the "
            "model event of the transcript shows it]")


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


def planner_line(episode: PlannedEpisode, key: EpisodeKey, error: str, elapsed_s: float
                 ) -> dict[str, Any]:
    """The result line of an episode the planner's own code ended, as `cocobench run`
    writes it (`planner_error_line`)."""
    spec = episode.spec
    return planner_error_line(key, error, unrun_result(
        spec.config, planner=spec.planner, obs_mode=spec.obs_mode, backend=spec.backend,
        prompt_suite=spec.prompt_suite, elapsed_s=round(elapsed_s, 3)))


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
