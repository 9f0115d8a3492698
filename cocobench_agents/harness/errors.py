"""Why a run stops before its plan is done: typed exceptions, for the command line to map to
exit codes.

Each is raised once what finished is recorded, so `--resume` (with `--retry-errors` after a
fatal model error) completes the run; each pickles by its arguments, so a worker process can
send one to its parent.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from cocobench_agents.runfolder.infra import unanswered_calls

#: The `ModelError` kinds no retry and no later episode can get past, and what they mean.
FATAL_KINDS = {
    "auth": "the provider refused the credentials",
    "not_found": "the provider does not know the model (or the endpoint)",
    "unsupported_input": "the model does not take the input sent (an image, for a text-only "
                         "model)",
}
#: What to do about each fatal kind before re-running the failed episodes.
FIXES = {
    "auth": "Fix the key",
    "not_found": "Fix the model name or --api-base",
    "unsupported_input": "Serve a model that takes images at that address (llama.cpp: start "
                         "it with its --mmproj file; or start a new run with --obs blind)",
}


class WorkerError(RuntimeError):
    """A worker (a process, or a Ray worker) died or could not start, so episodes are missing
    or none ran."""


class FatalModelError(RuntimeError):
    """A model call failed in a way that fails every later call too (an authentication
    error, a model that does not exist, an input the model does not take): the run stopped
    starting episodes; those in flight finished and are recorded (as backend errors, like
    the one that raised this)."""

    def __init__(self, model: str, kind: str, detail: str) -> None:
        super().__init__(model, kind, detail)
        self.model, self.kind, self.detail = model, kind, detail

    @property
    def fix(self) -> str:
        """What to do about it (a sentence without its full stop)."""
        return FIXES.get(self.kind, "Fix the model's settings")

    def __str__(self) -> str:
        return (f"{self.model}: {FATAL_KINDS.get(self.kind, self.kind)} ({self.detail}); "
                "the run stopped starting episodes")


class WorkerEnvironmentError(RuntimeError):
    """A Ray worker's node lacks a variable the run's models need (a key): the run stops
    before any episode runs there. `variables` are names ("A or B": either will do), never
    values."""

    def __init__(self, variables: Sequence[str], node: str, host: str) -> None:
        super().__init__(tuple(variables), node, host)
        self.variables, self.node, self.host = tuple(variables), node, host

    def __str__(self) -> str:
        missing = ", ".join(self.variables)
        return (f"the Ray worker on node {self.node} ({self.host}) lacks {missing}: model "
                "keys are read where the calls are made, so set the variable in that node's "
                "environment before `ray start` (see docs/distributed.md, \"Model keys on the "
                "workers\")")


class WorkersLost(WorkerError):
    """No Ray worker was alive for the run's `wait_s` (`cause`: why); what finished is
    recorded, `left` episodes are not."""

    def __init__(self, wait_s: float, left: int, cause: str) -> None:
        super().__init__(wait_s, left, cause)
        self.wait_s, self.left, self.cause = wait_s, left, cause

    def __str__(self) -> str:
        return (f"no Ray worker has been alive for {self.wait_s:g} s (--ray-wait): "
                f"{self.cause}; {self.left} episode{'s' if self.left != 1 else ''} did not "
                "run: add nodes (or free the cluster) and finish the run with --resume")


def fatal_model_error(record: Mapping[str, Any], document: Mapping[str, Any] | None
                      ) -> FatalModelError | None:
    """The first fatal model failure of an episode (its result line and trajectory), if
    any. Only episodes with backend errors are read: costs nothing otherwise."""
    if document is None or not unanswered_calls(record):
        return None
    # Every decision, an idle agent's too (one of a heterogeneous team whose model refused
    # the key idles while the others act: its decision is on no step).
    for decision in document.get("planner_decisions") or []:
        kind = decision.get("error_kind")
        if decision.get("status") == "backend_error" and kind in FATAL_KINDS:
            return FatalModelError(str(decision.get("model")), kind, str(decision.get("error")))
    return None
