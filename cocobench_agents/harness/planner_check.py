"""The check a planner from the researcher's code passes before any episode of a run.

It builds (its rounds, or a graph that declares no runtime context other than
`PlannerContext`), and one episode on a demo instance with the `greedy` model ends with a
recorded terminal reason, every request it sends one an OpenAI-compatible server takes
(`models.chat_schema`: roles, content parts, images; greedy itself never reads them). A
planner that fails is a `PlannerError` (exit 2) saying what is wrong, before anything is
written; the run never records a hundred identical crashes instead.
"""

from __future__ import annotations

import asyncio
import sysconfig
import traceback
from collections.abc import Iterable
from pathlib import Path

from benchmark_adapter.tasks import load_tasks
from benchmark_adapter.vocabulary import BLIND, DEMO_SUITE
from cocobench_agents.episode_runner import EpisodeSpec, run_episode
from cocobench_agents.graphs import (
    PlannerContext,
    PlannerError,
    compiled_graph,
    planner_rounds,
    planner_spec,
)
from cocobench_agents.graphs.node_errors import EndlessLoop, PlannerNodeError
from cocobench_agents.graphs.plugins import LoadedPlanner, describe_error, user_planners
from cocobench_agents.models import ModelClient, ModelError, ModelPool, ModelReply, ModelRequest
from cocobench_agents.models.chat_schema import request_problem

CHECK_TASK = "G_D1__DemoLivingRoom1__seed0"  # the demo suite's two-agent instance

_PASSED: set[tuple[str, str | None]] = set()  # per process: each version is checked once


def check_planners(names: Iterable[str]) -> None:
    """Check every user planner among `names` (built-ins need no check)."""
    todo = [p.name for p in user_planners(names) if _version(p) not in _PASSED]
    if todo:
        asyncio.run(check_planners_async(todo))


async def check_planners_async(names: Iterable[str]) -> None:
    """`check_planners` for code already inside an event loop."""
    for loaded in user_planners(names):
        if _version(loaded) not in _PASSED:
            await _check(loaded.name)
            _PASSED.add(_version(loaded))


def _version(loaded: LoadedPlanner) -> tuple[str, str | None]:
    return loaded.name, loaded.origin.sha256


async def _check(name: str) -> None:
    _build(name)
    config = next(t for t in load_tasks(DEMO_SUITE) if t.task_id == CHECK_TASK)
    spec = EpisodeSpec(config, planner=name, models={"*": "greedy"}, obs_mode=BLIND)
    pool = CheckingPool()
    try:
        _, result = await run_episode(spec, pool)
    except PlannerNodeError as exc:
        _refuse_what_a_server_refuses(name, pool)  # what the node then tripped on
        if isinstance(exc.__cause__, EndlessLoop):
            raise PlannerError(f"planner {name}: its check episode ({CHECK_TASK}, greedy) did "
                               "not end; end a step with observe_next (it stops on the step "
                               "budget) and route with continue_or_end: "
                               f"{exc.failure.headline()}") from None
        # A node's exception comes with its node, file, line and last frames.
        raise PlannerError(f"planner {name}: its check episode ({CHECK_TASK}, greedy) failed: "
                           f"{exc}") from None
    except Exception as exc:  # noqa: BLE001 - any failure of user code fails the check
        raise PlannerError(f"planner {name}: its check episode ({CHECK_TASK}, greedy) failed: "
                           f"{describe_error(exc)}") from None
    _refuse_what_a_server_refuses(name, pool)
    if not result.terminal_reason:
        raise PlannerError(f"planner {name}: its check episode ({CHECK_TASK}, greedy) ended "
                           "without a recorded terminal reason; end through land_round or "
                           "observe_next, or record the stop with ctx.tools.stop(decision)")


def _build(name: str) -> None:
    """Build the planner as its episodes play it: its rounds, or for a strategy that gives
    just a graph, the compiled graph, whose runtime context must be `PlannerContext` (a
    round's graph is built with it). Only the graph imports LangGraph."""
    try:
        if planner_rounds(name) is not None:
            return
        graph = compiled_graph(name)
    except PlannerError:
        raise
    except Exception as exc:  # noqa: BLE001 - the user's build function may raise anything
        what = "rounds" if planner_spec(name).rounds is not None else "graph"
        raise PlannerError(f"planner {name}: building its {what} failed: "
                           f"{describe_error(exc)}") from None
    schema = getattr(graph, "context_schema", None)
    if schema is not None and not issubclass(PlannerContext, schema):
        raise PlannerError(f"planner {name}: its graph declares context_schema="
                           f"{schema.__name__}; planner graphs run with PlannerContext")


def _refuse_what_a_server_refuses(name: str, pool: CheckingPool) -> None:
    if pool.refused:
        raise PlannerError(f"planner {name}: its check episode ({CHECK_TASK}, greedy) sent a "
                           "request an OpenAI-compatible server refuses (HTTP 400): "
                           f"{pool.refused[0]}")


class CheckingPool(ModelPool):
    """The check's models: every request is checked as a server would check it
    (`request_problem`) before the offline model answers; a refused one is kept in
    `refused` (what, and the line of the strategy that sent it) and fails its call as a
    server's HTTP 400 does (a `bad_request`, which is not retried)."""

    def __init__(self) -> None:
        super().__init__()
        self.refused: list[str] = []

    def client(self, spec: str, *, episode: str, agent: str | None) -> ModelClient:
        return _CheckedClient(super().client(spec, episode=episode, agent=agent), self.refused)


class _CheckedClient:
    def __init__(self, client: ModelClient, refused: list[str]) -> None:
        self.client, self.refused = client, refused
        self.name = client.name
        self.accepts_images = getattr(client, "accepts_images", True)

    async def complete(self, request: ModelRequest) -> ModelReply:
        problem = request_problem(request)
        if problem is not None:
            sender = _sender()
            self.refused.append(f"{problem}" + (f" (sent from {sender})" if sender else ""))
            raise ModelError("bad_request", f"an OpenAI-compatible server refuses it: {problem}")
        return await self.client.complete(request)


def _sender() -> str | None:
    """Where the strategy's code made the call being checked: the innermost frame of the
    stack outside cocobench and the installed packages, as "FILE, line N"."""
    ours = Path(__file__).resolve().parents[1]  # cocobench_agents/
    installed = {Path(p).resolve() for p in (sysconfig.get_paths()["purelib"],
                                            sysconfig.get_paths()["stdlib"])}
    for frame in reversed(traceback.extract_stack()):
        path = Path(frame.filename).resolve()
        if not path.is_relative_to(ours) and not any(path.is_relative_to(p) for p in installed):
            return f"{frame.filename}, line {frame.lineno}"
    return None
