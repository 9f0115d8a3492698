"""`episode`: a whole CoCoBench episode as one LangGraph graph, for LangGraph's own tooling.

The planner graphs need a live `Episode` in their runtime context, which a LangGraph server
cannot supply; this graph takes plain input (`{task, model, planner, obs_mode,
model_settings}`, the last with a run request's fields and validation), builds the
episode itself, runs the chosen planner inside its `play` node, streams one custom event per
landed step (``stream_mode="custom"``) and returns the scored result. `langgraph dev` serves it
(see `langgraph.json`), and `langgraph_sdk`'s ``runs.wait`` / ``runs.stream`` run it.

Human seats (``model: "human"``, or ``agent_models: {"agent_1": "human"}``) pause the graph:
`play` runs the episode with the answers given so far and stops it at the first decision
without one; `ask` shows that decision in a LangGraph `interrupt` and keeps the answer it is
resumed with (``Command(resume={"action_id": 3, "reason": …, "message": …})``, checked
against the decision's menu); then `play` plays the episode again from its start, replaying
every answer (the episode is deterministic for given answers), up to the next decision.

It is a door onto the episode runner, as `cocobench run` is, so it sits above the runner (the
planner graphs in `graphs/` sit below it).
"""

from __future__ import annotations

import asyncio
import dataclasses
from collections.abc import Callable
from typing import Any

from langgraph.config import get_stream_writer
from langgraph.graph import END, START, StateGraph
from langgraph.types import interrupt
from pydantic import BaseModel, ConfigDict, Field, field_validator
from typing_extensions import NotRequired, TypedDict

from benchmark_adapter.vocabulary import (
    DEFAULT_TASKS,
    Backend,
    ObservationMode,
)
from cocobench_agents.engine.resolve import find_task
from cocobench_agents.episode_runner import DEFAULT_MODEL_KEY, EpisodeSpec, run_episode
from cocobench_agents.graphs import planner_spec
from cocobench_agents.harness.human_log import answer_of, answers_again
from cocobench_agents.models import ModelPool, ModelSettings
from cocobench_agents.models.human import Answer, Decision, HumanTurn
from cocobench_agents.prompts import load_prompt_suite
from cocobench_agents.tools import prompt_hash


class EpisodeInput(TypedDict):
    """What to run (Studio shows this as the input form)."""

    task: str  # a task-config file, or an instance id of `suite`
    suite: NotRequired[str]  # where `task` ids are looked up (default cocobench-240)
    model: NotRequired[str]  # a built-in (greedy, random[:SEED], human, …) or a LiteLLM model
    #: Another model for some agents of a decentralized team ({"agent_1": "human"}).
    agent_models: NotRequired[dict[str, str]]
    planner: NotRequired[str]  # a registered planner (default centralized)
    obs_mode: NotRequired[ObservationMode]
    budget: NotRequired[int]  # landed steps allowed (default: the instance's step budget)
    backend: NotRequired[Backend]
    prompt_suite: NotRequired[str]
    #: How remote models are called: the fields of `ModelSettings`, as in a run request's
    #: ``model_settings`` (api_base, api_key_env — a variable's NAME —, temperature, …).
    model_settings: NotRequired[dict[str, Any]]


class EpisodeOutput(TypedDict):
    """The scored episode."""

    result: dict[str, Any]  # the result line a run would append to results.jsonl
    trajectory: dict[str, Any]  # a summary: steps, terminal reason, decisions, goal


class EpisodeState(EpisodeInput, EpisodeOutput, total=False):
    """Input and output together, and the human seats' play so far."""

    answers: dict[str, dict[str, Any]]  # decision id → the person's answer, its prompt's hash
    pending: dict[str, Any] | None  # the decision `ask` shows next (`Decision.as_dict`)
    streamed: int  # the steps already streamed (a replay does not stream them again)


def episode_spec(state: EpisodeInput) -> EpisodeSpec:
    """The episode `state` asks for: its task found as `cocobench prompts show` finds one
    (`find_task`), and what it leaves out as a run leaves it (`EpisodeSpec`'s defaults, the
    request's task source)."""
    config = find_task(state["task"], state.get("suite") or DEFAULT_TASKS)
    given = {field: state[key] for key, field in _SPEC_FIELDS.items()  # type: ignore[literal-required]
             if state.get(key) not in (None, "")}
    spec = EpisodeSpec(config=config, **given)
    models = dict(spec.models)
    if state.get("model"):
        models[DEFAULT_MODEL_KEY] = state["model"]
    if planner_spec(spec.planner).decentralized:  # as a run: only their agents have models
        models.update(state.get("agent_models") or {})
    return dataclasses.replace(spec, models=models)


#: `EpisodeInput` keys that are `EpisodeSpec` fields, and which.
_SPEC_FIELDS = {"planner": "planner", "obs_mode": "obs_mode", "prompt_suite": "prompt_suite",
                "backend": "backend", "budget": "max_steps"}


def step_event(item: dict[str, Any]) -> dict[str, Any]:
    """What a client is streamed for one landed step."""
    result = item.get("skill_result") or {}
    return {"step": item.get("step_index"), "agent": result.get("agent"),
            "call": item.get("label"), "success": result.get("success"),
            "error": result.get("errorMessage") or None,
            "goal_success": (item.get("eval") or {}).get("success")}


async def begin(state: EpisodeState) -> dict[str, Any]:
    """A new run (on a new thread, or again on one that played): no answers yet."""
    return {"answers": {}, "pending": None, "streamed": 0}


async def play(state: EpisodeState) -> dict[str, Any]:
    """Build the episode, run its planner to the end, score it; or stop at the first
    decision of a human seat that has no answer yet, to be asked."""
    loop = asyncio.get_running_loop()
    writer = get_stream_writer()
    streamed = landed = state.get("streamed") or 0

    def on_step(item: dict[str, Any]) -> None:
        nonlocal landed
        landed = item.get("step_index") or 0
        if landed > streamed:  # the steps before were streamed by the play that asked
            loop.call_soon_threadsafe(writer, step_event(item))

    desk = GivenAnswers(state.get("answers") or {})
    # The episode runs on a thread of its own: it reads files and spends CPU in the simulator,
    # and a LangGraph server forbids blocking calls on (and while) an event loop runs.
    try:
        outcome = await asyncio.to_thread(_play, dict(state), on_step, desk)
    except HumanTurn as turn:  # here, in the node: `ask` interrupts in its own context
        return {"pending": turn.decision.as_dict(), "streamed": max(streamed, landed)}
    return {**outcome, "pending": None}


async def ask(state: EpisodeState) -> dict[str, Any]:
    """Show the pending decision to the person (an interrupt) and keep their answer. A
    resume value that is not an answer on the decision's menu is refused (a validation
    error naming it and the menu), and the decision can be answered again."""
    decision: dict[str, Any] = state["pending"]  # type: ignore[assignment] - set by `play`
    schema = answer_schema([option["id"] for option in decision["menu"]])
    answer = interrupt(decision, response_schema=schema)
    given = {**answer.model_dump(), "prompt_hash": prompt_hash(decision["prompt"])}
    return {"answers": {**(state.get("answers") or {}), decision["id"]: given},
            "pending": None}


async def after_play(state: EpisodeState) -> str:
    return "ask" if state.get("pending") else END


class GivenAnswers:
    """A desk with the answers a person gave so far: the first decision asked without one
    (or whose situation changed since: a remote teammate that answered otherwise this time)
    stops the episode (`HumanTurn`) until it is asked."""

    def __init__(self, answers: dict[str, dict[str, Any]]) -> None:
        self.answers = answers
        self.first_unanswered: Decision | None = None

    async def ask(self, decision: Decision) -> Answer:
        given = self.answers.get(decision.id)
        if given is None or not answers_again(given, decision):
            # Seats deciding in parallel may all stop; whichever stop ends the episode names
            # the first asked, so the person answers in the order the planner asks.
            self.first_unanswered = self.first_unanswered or decision
            raise HumanTurn(self.first_unanswered)
        return answer_of(given)


def answer_schema(menu_ids: list[int]) -> type[BaseModel]:
    """What `ask` takes as a resume value for a decision offering `menu_ids` (LangGraph
    validates the value with it, and shows clients its JSON schema)."""

    class HumanAnswer(BaseModel):
        """A person's answer: a menu id (null: DONE), why (optional) and, in D1, a
        message."""

        model_config = ConfigDict(extra="forbid")

        action_id: int | None = Field(  # None: DONE (every goal is satisfied)
            json_schema_extra={"enum": [*menu_ids, None]})
        reason: str = ""
        message: str = ""
        think_s: float = Field(0.0, ge=0)

        @field_validator("action_id")
        @classmethod
        def _on_menu(cls, action_id: int | None) -> int | None:
            if action_id is not None and action_id not in menu_ids:
                raise ValueError(f"action {action_id} is not on the menu (ids: "
                                 f"{', '.join(map(str, menu_ids))}; null: DONE)")
            return action_id

    return HumanAnswer


def _play(state: dict[str, Any], on_step: Callable[[dict[str, Any]], None],
          desk: GivenAnswers) -> dict[str, Any]:
    spec = episode_spec(state)  # type: ignore[arg-type]
    settings = ModelSettings.model_validate(state.get("model_settings") or {})
    # read now, before the episode's event loop starts (with its planner's own templates)
    load_prompt_suite(spec.prompt_suite, planner_spec(spec.planner).templates)
    document, result = asyncio.run(_run(spec, ModelPool(settings, desk=desk),
                                        spec.controller(), on_step))
    return {"result": {**result.model_dump(mode="json"), "model": spec.model_for(None)},
            "trajectory": trajectory_summary(document)}


async def _run(spec: EpisodeSpec, pool: ModelPool, controller: Any,
               on_step: Callable[[dict[str, Any]], None]) -> tuple[dict[str, Any], Any]:
    try:
        return await run_episode(spec, pool, controller=controller, on_step=on_step)
    finally:
        await pool.aclose()


def trajectory_summary(document: dict[str, Any]) -> dict[str, Any]:
    """The trajectory in brief (the full document stays with `cocobench run`)."""
    items = document.get("trajectory", [])
    steps = [step_event(i) for i in items if "skill_result" in i]
    final = document.get("final_eval") or {}
    return {"task_id": document.get("task_id"), "steps": steps,
            "success": final.get("success"), "last": items[-1].get("label") if items else None,
            "decisions": len(document.get("planner_decisions", []))}


def build_episode_graph() -> StateGraph:
    """START → begin → play → (ask → play | END), with the input and output schemas above."""
    graph = StateGraph(EpisodeState, input_schema=EpisodeInput, output_schema=EpisodeOutput)
    graph.add_node("begin", begin)
    graph.add_node("play", play)
    graph.add_node("ask", ask)
    graph.add_edge(START, "begin")
    graph.add_edge("begin", "play")
    graph.add_conditional_edges("play", after_play, ["ask", END])
    graph.add_edge("ask", "play")
    return graph


#: The compiled graph `langgraph.json` serves as `episode`.
episode = build_episode_graph().compile()
