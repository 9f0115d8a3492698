"""`episode`: a whole CoCoBench episode as one LangGraph graph, for LangGraph's own tooling.

The planner graphs need a live `Episode` in their runtime context, which a LangGraph server
cannot supply; this graph takes plain input (`{task, model, planner, obs_mode,
model_settings}`, the last with a run request's fields and validation), builds the
episode itself, runs the chosen planner inside its one node, streams one custom event per
landed step (``stream_mode="custom"``) and returns the scored result. `langgraph dev` serves it
(see `langgraph.json`), and `langgraph_sdk`'s ``runs.wait`` / ``runs.stream`` run it.

It is a door onto the episode runner, as `cocobench run` is, so it sits above the runner (the
planner graphs in `graphs/` sit below it).
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from pathlib import Path
from typing import Any, Literal

from langgraph.config import get_stream_writer
from langgraph.graph import END, START, StateGraph
from typing_extensions import NotRequired, TypedDict

from benchmark_adapter.tasks import TaskConfig, load_task, load_tasks
from cocobench_agents.episode_runner import DEFAULT_MODEL_KEY, EpisodeSpec, run_episode
from cocobench_agents.models import ModelPool, ModelSettings
from cocobench_agents.prompts import DEFAULT_SUITE, load_prompt_suite

DEFAULT_SOURCE = "cocobench-240"


class EpisodeInput(TypedDict):
    """What to run (Studio shows this as the input form)."""

    task: str  # a task-config file, or an instance id of `suite`
    suite: NotRequired[str]  # where `task` ids are looked up (default cocobench-240)
    model: NotRequired[str]  # a built-in (greedy, random[:SEED], …) or a LiteLLM model string
    planner: NotRequired[str]  # a registered planner (default centralized)
    obs_mode: NotRequired[Literal["image", "blind"]]
    budget: NotRequired[int]  # landed steps allowed (default: the instance's step budget)
    backend: NotRequired[Literal["embedded", "ai2thor"]]
    prompt_suite: NotRequired[str]
    #: How remote models are called: the fields of `ModelSettings`, as in a run request's
    #: ``model_settings`` (api_base, api_key_env — a variable's NAME —, temperature, …).
    model_settings: NotRequired[dict[str, Any]]


class EpisodeOutput(TypedDict):
    """The scored episode."""

    result: dict[str, Any]  # the result line a run would append to results.jsonl
    trajectory: dict[str, Any]  # a summary: steps, terminal reason, decisions, goal


class EpisodeState(EpisodeInput, EpisodeOutput, total=False):
    """Input and output together."""


def resolve_task(task: str, suite: str = DEFAULT_SOURCE) -> TaskConfig:
    """The config of `task`: a config file, or an instance id of `suite`."""
    if Path(task).is_file():
        return load_task(task)
    for config in load_tasks(suite):
        if config.task_id == task:
            return config
    raise ValueError(f"unknown task {task!r}: neither a task-config file nor an instance id "
                     f"of {suite!r} (see `cocobench list {suite}`)")


def episode_spec(state: EpisodeInput) -> EpisodeSpec:
    """The episode `state` asks for, with the documented defaults."""
    config = resolve_task(state["task"], state.get("suite") or DEFAULT_SOURCE)
    return EpisodeSpec(config=config, planner=state.get("planner") or "centralized",
                       models={DEFAULT_MODEL_KEY: state.get("model") or "greedy"},
                       obs_mode=state.get("obs_mode") or "image",
                       prompt_suite=state.get("prompt_suite") or DEFAULT_SUITE,
                       backend=state.get("backend") or "embedded",
                       max_steps=state.get("budget"))


def step_event(item: dict[str, Any]) -> dict[str, Any]:
    """What a client is streamed for one landed step."""
    result = item.get("skill_result") or {}
    return {"step": item.get("step_index"), "agent": result.get("agent"),
            "call": item.get("label"), "success": result.get("success"),
            "error": result.get("errorMessage") or None,
            "goal_success": (item.get("eval") or {}).get("success")}


async def play(state: EpisodeState) -> dict[str, Any]:
    """Build the episode, run its planner to the end, score it."""
    loop = asyncio.get_running_loop()
    writer = get_stream_writer()

    def on_step(item: dict[str, Any]) -> None:
        loop.call_soon_threadsafe(writer, step_event(item))

    # The episode runs on a thread of its own: it reads files and spends CPU in the simulator,
    # and a LangGraph server forbids blocking calls on (and while) an event loop runs.
    return await asyncio.to_thread(_play, dict(state), on_step)


def _play(state: dict[str, Any], on_step: Callable[[dict[str, Any]], None]) -> dict[str, Any]:
    spec = episode_spec(state)  # type: ignore[arg-type]
    settings = ModelSettings.model_validate(state.get("model_settings") or {})
    load_prompt_suite(spec.prompt_suite)  # read now, before the episode's event loop starts
    document, result = asyncio.run(_run(spec, settings, spec.controller(), on_step))
    return {"result": {**result.model_dump(mode="json"), "model": spec.model_for(None)},
            "trajectory": trajectory_summary(document)}


async def _run(spec: EpisodeSpec, settings: ModelSettings, controller: Any,
               on_step: Callable[[dict[str, Any]], None]) -> tuple[dict[str, Any], Any]:
    pool = ModelPool(settings)
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
    """START → play → END, with the input and output schemas above."""
    graph = StateGraph(EpisodeState, input_schema=EpisodeInput, output_schema=EpisodeOutput)
    graph.add_node("play", play)
    graph.add_edge(START, "play")
    graph.add_edge("play", END)
    return graph


#: The compiled graph `langgraph.json` serves as `episode`.
episode = build_episode_graph().compile()
