"""The check a planner from the researcher's code passes before any episode of a run.

It compiles, it declares no runtime context other than `PlannerContext`, and one episode on
a demo instance with the `greedy` model ends with a recorded terminal reason. A planner that
fails is a `PlannerError` (exit 2) saying what is wrong, before anything is written; the run
never records a hundred identical crashes instead.
"""

from __future__ import annotations

import asyncio
from collections.abc import Iterable

from benchmark_adapter.tasks import load_tasks
from benchmark_adapter.vocabulary import BLIND, DEMO_SUITE
from cocobench_agents.episode_runner import EpisodeSpec, run_episode
from cocobench_agents.graphs import PlannerContext, PlannerError, compiled_graph
from cocobench_agents.graphs.node_errors import EndlessLoop, PlannerNodeError
from cocobench_agents.graphs.plugins import LoadedPlanner, describe_error, user_planners
from cocobench_agents.models import ModelPool

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
    try:
        graph = compiled_graph(name)
    except PlannerError:
        raise
    except Exception as exc:  # noqa: BLE001 - the user's build function may raise anything
        raise PlannerError(f"planner {name}: building its graph failed: {describe_error(exc)}"
                           ) from None
    schema = getattr(graph, "context_schema", None)
    if schema is not None and not issubclass(PlannerContext, schema):
        raise PlannerError(f"planner {name}: its graph declares context_schema="
                           f"{schema.__name__}; planner graphs run with PlannerContext")
    config = next(t for t in load_tasks(DEMO_SUITE) if t.task_id == CHECK_TASK)
    spec = EpisodeSpec(config, planner=name, models={"*": "greedy"}, obs_mode=BLIND)
    try:
        _, result = await run_episode(spec, ModelPool())
    except PlannerNodeError as exc:
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
    if not result.terminal_reason:
        raise PlannerError(f"planner {name}: its check episode ({CHECK_TASK}, greedy) ended "
                           "without a recorded terminal reason; end through land_round or "
                           "observe_next, or record the stop with ctx.tools.stop(decision)")
