"""The executors by name: the request's ``execution.executor`` picks one.

Adding an executor is a module implementing `executor.Executor` and its registration: a line
in `EXECUTORS` here, and its name in `ExecutorName` (what a request may name, beside the
request's other execution settings); see docs/distributed.md. Each is imported when it is
picked: Ray only when a Ray run starts.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from cocobench_agents.harness.executor import Executor

#: Where a run a person plays goes, whatever the request names: this process, in turn.
IN_PROCESS = "in-process"

EXECUTORS: dict[str, str] = {
    IN_PROCESS: "cocobench_agents.harness.batch:InProcess",
    "local": "cocobench_agents.harness.workers:WorkerProcesses",
    "ray": "cocobench_agents.harness.ray_executor:RayExecutor",
}


def executor_named(name: str) -> Executor:
    """A new executor of the kind `name` registers."""
    module, _, attribute = EXECUTORS[name].partition(":")
    return getattr(importlib.import_module(module), attribute)()
