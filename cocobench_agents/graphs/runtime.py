"""What a round's nodes are given when `rounds.play_rounds` awaits them directly, and the name
a router returns to end the graph, both without importing LangGraph: an episode of a planner
that declares its rounds runs without it, and importing it (with langchain-core and langsmith)
was about half of a run's serial start.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

#: What a router returns to end the graph: LangGraph's `langgraph.graph.END`, the same string
#: (a test pins that they are equal).
END = "__end__"


def _no_stream(_chunk: Any) -> None:
    """A stream writer outside `stream_mode="custom"`: what is written goes nowhere, as with
    LangGraph's default."""


@dataclass(frozen=True)
class RoundRuntime:
    """The `runtime` argument of a node played by the plain loop: the fields of LangGraph's
    `Runtime` that a node of a graph compiled without a store sees, with the same values
    (a test pins the names against LangGraph's). Nodes read `runtime.context`."""

    context: Any = None
    store: Any = None
    stream_writer: Callable[[Any], None] = _no_stream
    previous: Any = None
