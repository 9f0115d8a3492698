"""Why a run could not start or did not finish. Each message says what to do next; what was
recorded before is kept and valid in every case."""

from __future__ import annotations

import shlex
import sys
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from cocobench_agents.harness.errors import FatalModelError


class RequestError(ValueError):
    """A request that cannot run as asked: a mistake of the user's (nothing is run)."""


# Mistakes in what the user asked for (the command line reports them in one line, exit 2;
# `evaluate` raises `EvaluationError`). By module and name, so that checking an error imports
# nothing new.
USER_ERRORS = {
    "benchmark_adapter.tasks.errors": "TaskConfigError",
    "benchmark_adapter.sim.thor.errors": "ThorUnavailable",
    "cocobench_agents.models.errors": "ModelConfigError",
    "cocobench_agents.models.preflight": "PreflightError",
    "cocobench_agents.runfolder.errors": "RunFolderError",
    "cocobench_agents.runfolder.lock": "RunLocked",
    "cocobench_agents.harness.episodes": "PlanError",
    "cocobench_agents.harness.ray_session": "RayUnavailable",
    "cocobench_agents.harness.errors": "WorkerEnvironmentError",
    "cocobench_agents.prompts.suite": "PromptSuiteError",
    "cocobench_agents.graphs.registry": "PlannerError",
    "cocobench_agents.engine.errors": "RequestError",
    "cocobench_agents.engine.config": "ConfigError",
}


def is_user_error(exc: BaseException, errors: dict[str, str] = USER_ERRORS) -> bool:
    """Whether `exc` reports a mistake in the user's input (its module is loaded if it was
    raised)."""
    return any(isinstance(exc, getattr(sys.modules[module], name))
               for module, name in errors.items() if module in sys.modules)


def resume_command(folder: Path, *extra: str) -> str:
    """The command that finishes the run in `folder`."""
    return " ".join(["cocobench run --out", shlex.quote(str(folder)), "--resume", *extra])


class RunStopped(Exception):
    """The run stopped before every episode was recorded."""

    def __init__(self, message: str, folder: Path) -> None:
        super().__init__(message)
        self.folder = folder


class RunInterrupted(RunStopped):
    """Ctrl-C (KeyboardInterrupt) during a run."""

    def __init__(self, folder: Path, done: int, total: int) -> None:
        super().__init__(f"interrupted: {done} of {total} episodes are recorded in {folder}; "
                         f"finish the run with: {resume_command(folder)}", folder)


class RunFolderFailed(RunStopped):
    """The run folder could not be written (a full disk, an I/O error)."""

    def __init__(self, folder: Path, error: Exception) -> None:
        super().__init__(f"the run stopped: {error}. What it recorded is kept and valid; make "
                         "room (or fix the folder) and finish the run with: "
                         f"{resume_command(folder)}", folder)


class ExecutorFailed(RunStopped):
    """The executor itself failed (a worker process died, a Ray cluster went away)."""


class ModelRefused(RunStopped):
    """The provider refused the key, knows no such model or refused the input: every later
    call would fail the same way, so the run stopped starting episodes (those in flight
    finished)."""

    def __init__(self, folder: Path, error: FatalModelError) -> None:
        super().__init__(f"{error}. {error.fix}, then re-run the failed episodes with: "
                         f"{resume_command(folder, '--retry-errors')}", folder)
