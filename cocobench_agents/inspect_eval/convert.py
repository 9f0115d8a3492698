"""An Inspect log of the `cocobench` task as a run folder (``cocobench import-inspect LOG
--out RUN``): `run.json` from the request the task recorded, each sample's trajectory and
result line as `cocobench run` writes them, so that `cocobench view`, `report` and `score`
read the episodes. A sample that ended in an error is an infrastructure error's line; one
an Inspect usage limit ended is scored as it stands."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from inspect_ai.log import EvalLog, EvalSample, read_eval_log

from benchmark_adapter.metrics import score_trajectory
from cocobench_agents.engine.records import run_record
from cocobench_agents.engine.request import RunRequest
from cocobench_agents.engine.resolve import resolve
from cocobench_agents.harness.batch import infra_error_record
from cocobench_agents.harness.episodes import PlannedEpisode
from cocobench_agents.partial_output import removed_on_failure
from cocobench_agents.runfolder.folder import RunFolder

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
    with removed_on_failure(folder.path):  # a full disk leaves nothing half-imported
        folder.create(run_record(resolved))
        records = [_record(folder, sample, episode) for sample, episode in samples]
        folder.append_results(records)  # one write and one fsync for them all
    errors = sum(bool(r.get("infra_error")) for r in records)
    return ImportedRun(Path(out), len(samples), errors)


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
    roles = {role: config.model for role, config in (log.eval.model_roles or {}).items()}
    return RunRequest.model_validate({
        **recorded, "out": out.resolve(), "models": [log.eval.model],
        "agent_models": {**recorded.get("agent_models", {}), **roles},
        "epochs": log.eval.config.epochs or 1})


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
        return {**line, "trajectory": folder.write_trajectory(key, document)}
    error = sample.error.message if sample.error is not None else "the sample left no result"
    record = infra_error_record(episode, error, sample.total_time or 0.0)
    if document is not None:
        record["trajectory"] = folder.write_trajectory(key, document)
    return record
