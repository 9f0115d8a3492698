"""An Inspect log of the `cocobench` task as a run folder (``cocobench import-inspect LOG
--out RUN``): `run.json` from the request the task recorded, each sample's trajectory and
result line as `cocobench run` writes them, so that `cocobench view`, `report` and `score`
read the episodes. A sample that ended in an error is an infrastructure error's line; one
an Inspect usage limit ended is scored as it stands."""

from __future__ import annotations

import json
import shlex
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from inspect_ai.log import EvalLog, EvalSample, read_eval_log

from benchmark_adapter.metrics import score_trajectory
from cocobench_agents.engine.records import run_record
from cocobench_agents.engine.request import RunRequest
from cocobench_agents.engine.resolve import resolve
from cocobench_agents.engine.resume import planner_code
from cocobench_agents.harness.batch import infra_error_record
from cocobench_agents.harness.episodes import PlannedEpisode
from cocobench_agents.models.settings import ModelSettings
from cocobench_agents.partial_output import removed_on_failure
from cocobench_agents.runfolder.folder import RunFolder
from cocobench_agents.runfolder.infra import inspect_retry_command

from .solver import RESULT, TRAJECTORY, result_line
from .task import REQUEST, sample_id


class InspectLogError(ValueError):
    """A file that is not an Inspect log of the `cocobench` task (the message names it)."""


@dataclass(frozen=True)
class ImportedRun:
    """What `import_log` wrote."""

    folder: Path
    episodes: int
    errors: int  # samples that ended in an error: infrastructure errors' lines
    status: str = "success"  # the log's: started or cancelled for an interrupted eval
    retry: str = ""  # the commands that complete or retry the eval, then import it again

    @property
    def incomplete(self) -> bool:
        """Whether the eval did not run to its end (interrupted, or stopped by an error)."""
        return self.status != "success"


def import_log(log_path: str | Path, out: str | Path) -> ImportedRun:
    """Write the run folder `out` (new) of the Inspect log at `log_path`. Every sample is
    checked against the recorded request before anything is written; a write that fails
    (`RunFolderWriteError`, `RunFolderError`) takes back what was written."""
    log = _read(Path(log_path))
    resolved = resolve(_request(log, Path(out)), notify=lambda _: None)
    planned = {(sample_id(p), p.key.epoch): p for p in resolved.episodes}
    samples = [(sample, _episode(sample, planned)) for sample in log.samples or []]
    folder = RunFolder(out)
    folder.check_unused()
    retry = inspect_retry_command(Path(log_path), Path(out))
    record = {**run_record(resolved), "command": inspect_command(log, seat_roles(log, Path(out))),
              # where the run came from, and how to complete or retry it (a report's advice)
              "imported_from": {"inspect_log": str(Path(log_path).resolve()),
                                "status": log.status, "retry": retry}}
    with removed_on_failure(folder.path):  # a full disk leaves nothing half-imported
        folder.create(record)
        records = [_record(folder, sample, episode) for sample, episode in samples]
        folder.append_results(records)  # one write and one fsync for them all
    errors = sum(bool(r.get("infra_error")) for r in records)
    return ImportedRun(Path(out), len(samples), errors, log.status, retry)


def seat_roles(log: EvalLog, out: Path) -> dict[str, str]:
    """The log's model roles that decided for an agent of its instances (role → model): a
    task built before its eval (from Python) took any role, and ignored the others."""
    recorded = {**log.eval.metadata[REQUEST], "out": out.resolve(), "models": [log.eval.model]}
    tasks = resolve(RunRequest.model_validate(recorded), notify=lambda _: None).tasks
    agents = {agent for task in tasks for agent in task.agent_ids}
    return {role: config.model for role, config in (log.eval.model_roles or {}).items()
            if role in agents}


def inspect_command(log: EvalLog, roles: dict[str, str]) -> str:
    """The ``inspect eval`` command that runs the log's eval again: its model, the model
    `roles` of its seats, its task parameters and epochs."""
    parts = ["inspect", "eval", "cocobench_agents/cocobench", "--model", log.eval.model]
    for role, model in roles.items():
        parts += ["--model-role", f"{role}={model}"]
    for name, value in (log.eval.task_args or {}).items():
        if value is not None:
            parts += ["-T", f"{name}={_task_arg(value)}"]
    if (log.eval.config.epochs or 1) > 1:
        parts += ["--epochs", str(log.eval.config.epochs)]
    return shlex.join(parts)


def _task_arg(value: Any) -> str:
    """A task parameter as ``-T`` takes it (a string as is; anything else as JSON, which
    Inspect reads as YAML)."""
    return value if isinstance(value, str) else json.dumps(value)


def _read(path: Path) -> EvalLog:
    if not path.is_file():
        raise InspectLogError(f"{path}: no such Inspect log")
    try:
        log = read_eval_log(str(path))
    except Exception as exc:  # noqa: BLE001 - any unreadable file is the same mistake
        raise InspectLogError(f"{path}: not an Inspect log ({type(exc).__name__}: {exc})"
                              ) from None
    if REQUEST not in (log.eval.metadata or {}):
        raise InspectLogError(f"{path}: a log of the task {log.eval.task!r}, not of "
                              "cocobench_agents/cocobench")
    return log


def _request(log: EvalLog, out: Path) -> RunRequest:
    """The request the task ran, with Inspect's model, model roles and epochs."""
    recorded: dict[str, Any] = dict(log.eval.metadata[REQUEST])
    code = planner_code(recorded)
    if code:  # a log is data: loading its planners would run code whoever wrote it chose
        raise InspectLogError(f"{log.location}: the task ran planners that are code "
                              f"({', '.join(map(str, code))}), which import-inspect never "
                              "loads from a log")
    roles = seat_roles(log, out)
    # the settings as run: Inspect's transport, and Inspect's --temperature where the task
    # sent none of its own
    settings = {**recorded.get("model_settings", {}), "transport": "inspect"}
    sent = ModelSettings.model_validate(settings).temperature_for(log.eval.model)
    temperature = log.eval.model_generate_config.temperature
    if sent is None and temperature is not None:
        settings["temperature"] = temperature
    return RunRequest.model_validate({
        **recorded, "out": out.resolve(), "models": [log.eval.model],
        "agent_models": {**recorded.get("agent_models", {}), **roles},
        "epochs": log.eval.config.epochs or 1, "model_settings": settings})


def _episode(sample: EvalSample, planned: dict[tuple[str, int], PlannedEpisode]
             ) -> PlannedEpisode:
    """The planned episode a sample ran (`InspectLogError` for one the request has none of)."""
    episode = planned.get((str(sample.id), sample.epoch - 1))
    if episode is None:
        raise InspectLogError(f"sample {sample.id!r} (epoch {sample.epoch}) is not an episode "
                              "of the recorded request")
    return episode


def _record(folder: RunFolder, sample: EvalSample, episode: PlannedEpisode) -> dict[str, Any]:
    """A sample's result line (its trajectory written). A sample an Inspect usage limit
    ended left its trajectory but no line: it is scored as it stands, as the scorer did."""
    line, document = sample.store.get(RESULT), sample.store.get(TRAJECTORY)
    key = episode.key
    if sample.error is None and document is not None:
        if line is None:
            line = result_line(score_trajectory(document, **episode.spec.identifiers()), key)
        # the wall time the report's Time column shows: the sample's, where the line has none
        return {"elapsed_s": round(sample.total_time or 0.0, 3), **line,
                "trajectory": folder.write_trajectory(key, document)}
    error = sample.error.message if sample.error is not None else "the sample left no result"
    record = infra_error_record(episode, error, sample.total_time or 0.0)
    if document is not None:
        record["trajectory"] = folder.write_trajectory(key, document)
    return record
