"""A planner's own failure, told as the strategy's author needs it: which node, the file and
line in the author's code, and the last frames of its traceback (LangGraph's own frames left
out). Three kinds: a node raised (`node_failure`); a node returned a malformed update, such
as a decision record without `status` (`checked_nodes` checks each update where the node
returns it, so the error names that node, not the framework node that would trip on it
later); the graph never ended (`endless_loop`: LangGraph's recursion limit, naming the last
nodes). `run_episode` records it in the trajectory and the run as a `planner_error`; the
console shows it.
"""

from __future__ import annotations

import functools
import inspect
import re
import traceback
from collections import deque
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from cocobench_agents.graphs.plugins import describe_error
from cocobench_agents.graphs.registry import PLANNERS

#: How LangGraph names the node (its task) on an exception raised inside it.
_TASK_NOTE = re.compile(r"During task with name '(?P<node>[^']+)'")
#: Where the frames that run nodes live (not the strategy's code): LangGraph, and the plain
#: loop of a planner's declared rounds (`rounds.py`, by path: importing it here would load
#: it on the CLI's light paths).
_RUNNER_PACKAGES = ("langgraph", "langchain_core")
_RUNNER_FILES = (__file__, str(Path(__file__).with_name("rounds.py")))
#: Exceptions of these modules are the infrastructure's wherever they are raised, never the
#: strategy's nor the model's: a simulator's (a Unity process that died) and the run folder's
#: (a human seat's answer log that cannot be read or written).
_INFRASTRUCTURE = ("benchmark_adapter.sim.", "cocobench_agents.runfolder.")
FRAMES = 3  # the traceback's last frames that are shown
LAST_NODES = 4  # how many of the last nodes a graph that never ended is named by


@dataclass(frozen=True)
class NodeFailure:
    """What a node's exception tells its author."""

    node: str
    error: str  # "KeyError: 'agent_1'"
    file: str | None  # where it raised, in the node's own file when the frames reach it
    line: int | None
    frames: tuple[str, ...]  # the last frames, innermost last, as Python prints them

    def headline(self) -> str:
        """One line: the error, the node and where it raised."""
        where = f" ({self.file}, line {self.line})" if self.file else ""
        return f"{self.error} in node {self.node!r}{where}"

    def describe(self) -> str:
        """The headline, then the traceback's last frames."""
        return "\n".join([self.headline(), *self.frames])

    def record(self) -> dict[str, Any]:
        """What the trajectory's stop decision keeps of it."""
        return {"error": self.headline(), "node": self.node, "file": self.file,
                "line": self.line, "traceback": list(self.frames)}


class PlannerNodeError(RuntimeError):
    """A planner graph's node raised: the episode stopped there. `document` is the
    trajectory up to that point, with the failure as its stop decision."""

    def __init__(self, failure: NodeFailure, document: dict[str, Any]) -> None:
        super().__init__(failure.describe())
        self.failure, self.document = failure, document


def is_strategy_code(planner: str) -> bool:
    """Whether `planner` is a researcher's strategy (a file, a module, an installed plugin),
    whose `PlannerNodeError` is its own `planner_error`; a built-in planner's is a failure of
    the harness (an infrastructure error), as is any planner's simulator failing."""
    return planner not in PLANNERS


def node_failure(exc: BaseException) -> NodeFailure | None:
    """How `exc` reads to the strategy's author, when a node of a planner graph raised it,
    returned a malformed update (`MalformedUpdate`) or the graph never ended (`EndlessLoop`);
    None when it did not come from the planner (the simulator: a failure of the
    infrastructure, not of the strategy)."""
    if isinstance(exc, MalformedUpdate):
        return NodeFailure(node=exc.node, error=describe_error(exc), file=exc.file,
                           line=exc.line,
                           frames=_def_frame(exc.file, exc.line, exc.function_name))
    if isinstance(exc, EndlessLoop):
        return endless_loop(exc.limit, exc.last_nodes, exc.graph)
    task = _TASK_NOTE.search("\n".join(getattr(exc, "__notes__", ())))
    if task is None or is_infrastructure_failure(exc):
        return None
    tb = traceback.extract_tb(exc.__traceback__)
    runner = max((i for i, frame in enumerate(tb) if _is_runner(frame)), default=-1)
    frames = tb[runner + 1:]  # from the node's function inwards
    # The innermost frame in the node's own file: a KeyError raised inside library code
    # still points at the author's line.
    origin = next(f for f in reversed(frames)
                  if f.filename == frames[0].filename) if frames else None
    shown = "".join(traceback.format_list(frames[-FRAMES:])).rstrip("\n")
    return NodeFailure(node=task["node"], error=describe_error(exc),
                       file=origin.filename if origin else None,
                       line=origin.lineno if origin else None,
                       frames=tuple(shown.splitlines()))


def is_infrastructure_failure(exc: BaseException) -> bool:
    """Whether `exc` is a simulator's or the run folder's own exception (`_INFRASTRUCTURE`):
    it ends the episode, or stops the run, as what it is, even from inside a node or a model
    client."""
    return type(exc).__module__.startswith(_INFRASTRUCTURE)


def _is_runner(frame: traceback.FrameSummary) -> bool:
    """A frame that runs nodes: LangGraph's, or the check around a node (`checked_nodes`)."""
    return frame.filename in _RUNNER_FILES or any(
        package in Path(frame.filename).parts for package in _RUNNER_PACKAGES)


# -- a node's update, checked where it is returned --------------------------------------------

#: The fields of a decision record the runner reads (docs/planners.md, "Decisions"), and what
#: each may hold.
DECISION_FIELDS: dict[str, tuple[type, ...]] = {
    "status": (str,), "agent": (str, type(None)), "parsed_call": (str, type(None)),
    "terminal_reason": (str, type(None)),
}
_CHECKED = "_cocobench_checked"  # marks a node function already wrapped
#: The parameters LangGraph fills by their name, after the state: `runtime` (whose `context`
#: is the `PlannerContext`), `config`, `writer`, `store`, `previous`, `error`.
FILLED_BY_NAME = ("runtime", "config", "writer", "store", "previous", "error")


class NodeSignatureError(TypeError):
    """A node function asks for a parameter LangGraph never passes (`rt` for `runtime`):
    every call of it would fail, so the graph is refused when it is built."""


class MalformedUpdate(TypeError):
    """A node of the strategy returned an update the runner cannot use (a decision record
    without `status`, say): raised where the node returns it, naming that node and where its
    function is defined."""

    def __init__(self, problem: str, node: str, function: Callable[..., Any]) -> None:
        super().__init__(problem)
        self.node, self.function_name = node, getattr(function, "__qualname__", node)
        self.file, self.line = source_of(function)


def checked_nodes(graph: Any) -> Any:
    """`graph` (a `StateGraph`, before it is compiled) with each node function's returned
    update checked (`update_problem`) as the node returns it; anything else is returned as
    it is. The check of a node's update costs a few dictionary lookups."""
    for name, node in getattr(graph, "nodes", {}).items():
        runnable = node.runnable
        if getattr(runnable, _CHECKED, False):
            continue
        function = getattr(runnable, "func", None) or getattr(runnable, "afunc", None)
        if callable(function):
            _check_signature(name, inspect.unwrap(function))
        for attribute in ("func", "afunc"):
            function = getattr(runnable, attribute, None)
            if callable(function):
                setattr(runnable, attribute, _checking(function, name))
                setattr(runnable, _CHECKED, True)
    return graph


def _check_signature(node: str, function: Callable[..., Any]) -> None:
    """Refuse a node function with a parameter, after the state, that has no default and is
    not one LangGraph fills by name (`FILLED_BY_NAME`)."""
    try:
        parameters = list(inspect.signature(function).parameters.values())[1:]
    except (TypeError, ValueError):  # no signature to read (a builtin): LangGraph's to judge
        return
    for parameter in parameters:
        if (parameter.default is inspect.Parameter.empty and parameter.name not in
                FILLED_BY_NAME and parameter.kind in (parameter.POSITIONAL_OR_KEYWORD,
                                                      parameter.KEYWORD_ONLY)):
            file, line = source_of(function)
            where = f" ({file}, line {line})" if file else ""
            raise NodeSignatureError(
                f"node {node!r}{where}: its parameter {parameter.name!r} is not one LangGraph "
                "passes; name it 'runtime' for the Runtime (runtime.context is the "
                "PlannerContext)")


def _checking(function: Callable[..., Any], node: str) -> Callable[..., Any]:
    """`function` (a node's, as LangGraph calls it) with its update checked on return."""
    user = inspect.unwrap(function)

    def check(update: Any) -> Any:
        problem = update_problem(update)
        if problem is not None:
            raise MalformedUpdate(problem, node, user)
        return update

    if inspect.iscoroutinefunction(function) or inspect.iscoroutinefunction(user):
        @functools.wraps(function)
        async def checked_async(*args: Any, **kwargs: Any) -> Any:
            return check(await function(*args, **kwargs))
        return checked_async

    @functools.wraps(function)
    def checked(*args: Any, **kwargs: Any) -> Any:
        return check(function(*args, **kwargs))
    return checked


def update_problem(update: Any) -> str | None:
    """What is wrong with a node's returned state update, in a sentence; None when the
    runner can use it. A dict is checked where the runner reads it: `pending` holds decision
    records (`DECISION_FIELDS`), `terminal_reason` is text or None, `round_index` a whole
    number; other keys are the strategy's own. LangGraph's own return values (a `Command`, a
    list of them, a state object) are left to LangGraph."""
    if update is None:
        return None
    if not isinstance(update, Mapping):
        if isinstance(update, (str, bytes, int, float, bool)):
            return (f"it returned {type(update).__name__} {update!r:.60}, not a dict of state "
                    "updates")
        return None
    pending = update.get("pending")
    if pending is not None:
        if not isinstance(pending, list):
            return f"'pending' is a {type(pending).__name__}, not a list of decision records"
        for index, record in enumerate(pending):
            problem = decision_problem(record)
            if problem is not None:
                return f"pending[{index}] {problem}"
    reason = update.get("terminal_reason")
    if reason is not None and not isinstance(reason, str):
        return f"'terminal_reason' is a {type(reason).__name__}, not text or None"
    index = update.get("round_index", 0)
    if not isinstance(index, int) or isinstance(index, bool):
        return f"'round_index' is a {type(index).__name__}, not a whole number"
    return None


def decision_problem(record: Any) -> str | None:
    """What keeps `record` from being a decision record the runner can land, or None."""
    if not isinstance(record, Mapping):
        return f"is a {type(record).__name__}, not a decision record (a dict)"
    for field, kinds in DECISION_FIELDS.items():
        if field not in record:
            return (f"has no {field!r} (a decision record carries "
                    f"{', '.join(DECISION_FIELDS)}: docs/planners.md, Decisions)")
        if not isinstance(record[field], kinds):
            expected = " or ".join("None" if k is type(None) else k.__name__ for k in kinds)
            return (f"has {field}={record[field]!r:.60}, a {type(record[field]).__name__}, "
                    f"not {expected}")
    return None


# -- a graph that never ends ------------------------------------------------------------------


class EndlessLoop(RecursionError):
    """A planner graph reached LangGraph's recursion limit without ending (`run_to_end`),
    or a planner's declared rounds as many supersteps (`rounds.play_rounds`); `graph` is the
    compiled graph or the `Rounds`."""

    def __init__(self, limit: int, last_nodes: Sequence[str], graph: Any) -> None:
        super().__init__(f"recursion limit of {limit} reached; the last nodes: "
                         f"{', '.join(last_nodes)}")
        self.limit, self.last_nodes, self.graph = limit, tuple(last_nodes), graph


async def run_to_end(graph: Any, state: Mapping[str, Any], *, context: Any,
                     config: dict[str, Any]) -> None:
    """Run compiled `graph` from `state` to its end, as `ainvoke` with
    ``stream_mode="updates"`` does (no state snapshots in between), keeping the names of the
    last nodes that ran: a graph that reaches its recursion limit raises `EndlessLoop`
    naming them."""
    # Imported here: the CLI's light paths (help, `prompts show`, user mistakes) reach this
    # module through the runner and must not load LangGraph.
    from langgraph.errors import GraphRecursionError

    ran: deque[str] = deque(maxlen=LAST_NODES)
    try:
        async for update in graph.astream(state, context=context, config=config,
                                          stream_mode="updates"):
            ran.extend(update)
    except GraphRecursionError as exc:
        raise EndlessLoop(config.get("recursion_limit", 0), list(ran), graph) from exc


def endless_loop(limit: int, last_nodes: Sequence[str], graph: Any) -> NodeFailure:
    """The failure of a planner graph that reached LangGraph's recursion limit of `limit`
    supersteps without ending: named by the last nodes that ran (`last_nodes`, oldest first)
    and where the last one's function is defined in `graph` (compiled)."""
    node = last_nodes[-1] if last_nodes else "?"
    function = node_function(graph, node)
    file, line = source_of(function) if function is not None else (None, None)
    ran = " -> ".join(last_nodes) or "none"
    error = (f"GraphRecursionError: the graph ran {limit} supersteps without ending (the "
             f"last nodes: {ran}); end it by routing to END once a terminal reason is set "
             "(observe_next stops on the step budget, continue_or_end routes)")
    name = getattr(function, "__qualname__", node)
    return NodeFailure(node=node, error=error, file=file, line=line,
                       frames=_def_frame(file, line, name))


def node_function(graph: Any, node: str) -> Callable[..., Any] | None:
    """The strategy's function behind `node` of compiled `graph` (or of a `Rounds`), or None
    (a subgraph)."""
    if hasattr(graph, "node_function"):  # a planner's declared rounds
        function = graph.node_function(node)
        return inspect.unwrap(function) if callable(function) else None
    spec = getattr(getattr(graph, "builder", None), "nodes", {}).get(node)
    runnable = getattr(spec, "runnable", None)
    function = getattr(runnable, "func", None) or getattr(runnable, "afunc", None)
    return inspect.unwrap(function) if callable(function) else None


def source_of(function: Callable[..., Any]) -> tuple[str | None, int | None]:
    """The file and the line where `function` is defined (its first line: a decorator's,
    when decorated); None for what has no Python source (a builtin, a partial)."""
    code = getattr(inspect.unwrap(function), "__code__", None)
    if code is None:
        return None, None
    return code.co_filename, code.co_firstlineno


def _def_frame(file: str | None, line: int | None, name: str) -> tuple[str, ...]:
    """A traceback's frame, as Python prints it, for the definition at `file`, `line`."""
    if file is None or line is None:
        return ()
    frame = traceback.FrameSummary(file, line, name)
    return tuple("".join(traceback.format_list([frame])).rstrip("\n").splitlines())
