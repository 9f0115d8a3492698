"""A planner node that raised, told as the strategy's author needs it: which node, the file
and line it raised at, and the last frames of its traceback (LangGraph's own frames left
out). `run_episode` records it in the trajectory; the console shows it.
"""

from __future__ import annotations

import re
import traceback
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from cocobench_agents.graphs.plugins import describe_error

#: How LangGraph names the node (its task) on an exception raised inside it.
_TASK_NOTE = re.compile(r"During task with name '(?P<node>[^']+)'")
#: Where the frames that run nodes live (not the strategy's code).
_RUNNER_PACKAGES = ("langgraph", "langchain_core")
#: The simulators' own exceptions (a Unity process that died) are infrastructure failures.
_SIMULATORS = "benchmark_adapter.sim."
FRAMES = 3  # the traceback's last frames that are shown


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


def node_failure(exc: BaseException) -> NodeFailure | None:
    """How `exc` reads to the strategy's author, when a node of a planner graph raised it;
    None when it did not come from a node (LangGraph's recursion limit, say) or came from
    the simulator (a failure of the infrastructure, not of the strategy)."""
    task = _TASK_NOTE.search("\n".join(getattr(exc, "__notes__", ())))
    if task is None or type(exc).__module__.startswith(_SIMULATORS):
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


def _is_runner(frame: traceback.FrameSummary) -> bool:
    return any(package in Path(frame.filename).parts for package in _RUNNER_PACKAGES)
