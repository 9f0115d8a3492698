"""Reading run folders into one table of episodes.

Each run folder's `results.jsonl` is read with `RunFolder.scan_results()`: every line is
validated (`runfolder.result_line.ResultLine`, pydantic); invalid lines are skipped and counted
in a warning, and a torn last line of a run in progress or a killed run is skipped (a note).
An episode whose latest line is invalid is left out. An episode is identified by
(model, condition, task_id, epoch): a later line supersedes an earlier one in the same run
(retries), and a later run supersedes an earlier one when several runs are reported together,
so the same model in several runs is merged into one set of episodes. A run with prompt-suite
arms reports each model once per arm, labelled ``MODEL @ARM`` (as `--arms` labels runs).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from benchmark_adapter.vocabulary import DIMENSIONS
from cocobench_agents.conditions import obs_mode_rank, split_condition
from cocobench_agents.reports.arms import arm_label, difference, recorded_settings, row_settings
from cocobench_agents.runfolder.errors import RunFolderError
from cocobench_agents.runfolder.folder import RESULTS, RUN_FILE, RunFolder
from cocobench_agents.runfolder.infra import is_infra_failure, is_planner_failure

INFRA_KIND = "infra_error"
PLANNER_KIND = "planner_error"  # the strategy's own code ended the episode
UNRECORDED_KIND = "unrecorded"

# Numeric columns: name -> how it is read from a result line (None when absent).
_NUMERIC = {
    "success": lambda r: r.get("task_success"),
    "progress": lambda r: r.get("task_progress"),
    "legal": lambda r: r.get("legal_plan"),
    "cs": lambda r: r.get("construct_score"),
    "steps": lambda r: r.get("num_steps"),
    "invalid_ratio": lambda r: r.get("num_invalid_action_ratio"),
    "dep": lambda r: _flag(r.get("dependency_violations")),
    "occ": lambda r: _flag(r.get("occupancy_conflicts")),
    "aff": lambda r: _flag(r.get("affordance_failures")),
    "ill": lambda r: _flag(r.get("illegal_skill")),
    "elapsed_s": lambda r: r.get("elapsed_s"),
    "planner_calls": lambda r: _usage(r, "model_calls", r.get("planner_steps")),
    "prompt_tokens": lambda r: _usage(r, "prompt_tokens"),
    "completion_tokens": lambda r: _usage(r, "completion_tokens"),
    "cost_usd": lambda r: _usage(r, "cost_usd"),
    "saved_cost_usd": lambda r: _usage(r, "saved_cost_usd"),
    "infra_failure": lambda r: float(is_infra_failure(r)),
    "planner_failure": lambda r: float(is_planner_failure(r)),
    "agent_count": lambda r: r.get("agent_count"),
    **{f"cross_{d}": (lambda r, d=d: _cross(r, d)) for d in DIMENSIONS},
}


class ReportError(RunFolderError):
    """A report that cannot be made as asked (a user mistake: one line, exit code 2)."""


class NotARunFolder(ReportError):
    """A path given to the report that is not a run folder."""


@dataclass(frozen=True)
class RunInfo:
    """What one run folder says about itself, and what was read from it."""

    path: Path
    name: str
    record: Mapping[str, Any]
    lines: int  # complete result lines
    torn_tail: bool  # an incomplete last line was skipped
    episodes: int  # distinct episodes after retries
    infra_errors: int  # among those episodes (see `is_infra_failure`)
    invalid_lines: int = 0  # result lines skipped: not JSON, or not a valid result
    missing_trajectories: int = 0  # episodes whose trajectory file is not in the folder

    @property
    def superseded(self) -> int:
        """Lines replaced by a later line of the same run."""
        return self.lines - self.episodes

    @property
    def plan(self) -> Mapping[str, Any]:
        plan = self.record.get("plan")
        return plan if isinstance(plan, Mapping) else {}

    @property
    def arms(self) -> list[str]:
        """The run's prompt-suite arms, in the order given (none for a single suite)."""
        return self._listed("arms")

    @property
    def models(self) -> list[str]:
        """The report rows' models the plan names: each model once per arm."""
        models = self._listed("models")
        return [arm_label(m, a) for m in models for a in self.arms] if self.arms else models

    @property
    def conditions(self) -> list[str]:
        return self._listed("conditions")

    @property
    def planned(self) -> int | None:
        """Episodes the run's plan asked for (None when run.json does not say, or says it in
        a shape no run writes: a run folder is data, whatever it holds)."""
        tasks, models, conds = (self._listed(key) for key in ("task_ids", "models", "conditions"))
        if not (tasks and models and conds):
            return None
        epochs = self.plan.get("epochs") or recorded_settings(self.record)[0].get("epochs") or 1
        if isinstance(epochs, bool) or not isinstance(epochs, int) or epochs < 1:
            return None
        return len(tasks) * len(models) * len(conds) * max(1, len(self.arms)) * epochs

    def _listed(self, key: str) -> list[str]:
        """The plan's list of names under `key` (empty when it holds anything else)."""
        value = self.plan.get(key)
        return [str(name) for name in value] if isinstance(value, list) else []


@dataclass
class Episodes:
    """All reported episodes as columns (one entry per episode, in a fixed order)."""

    text: dict[str, np.ndarray]  # model, condition, arch, obs, task_id, dim, failure_kind, ...
    numeric: dict[str, np.ndarray]  # float64, NaN where missing
    epoch: np.ndarray
    run_index: np.ndarray
    _codes: dict[str, tuple[dict[str, int], np.ndarray]] = field(default_factory=dict,
                                                                 repr=False)

    def __len__(self) -> int:
        return int(self.epoch.size)

    def col(self, name: str) -> np.ndarray:
        return self.numeric[name]

    def mask(self, **equal: Any) -> np.ndarray:
        """Episodes whose text columns equal the given values (None: no constraint)."""
        m = np.ones(len(self), dtype=bool)
        for key, value in equal.items():
            if value is not None:
                levels, codes = self._coded(key)
                m &= codes == levels.get(value, -1)
        return m

    def _coded(self, key: str) -> tuple[dict[str, int], np.ndarray]:
        """A text column as integer codes (comparing ints is much faster than strings)."""
        if key not in self._codes:
            levels: dict[str, int] = {}
            codes = np.array([levels.setdefault(v, len(levels)) for v in self.text[key]],
                             dtype=np.int32)
            self._codes[key] = (levels, codes)
        return self._codes[key]


@dataclass
class ReportData:
    """Episodes of one or several runs, merged, with the runs' metadata."""

    runs: list[RunInfo]
    episodes: Episodes
    models: list[str]
    conditions: list[str]
    superseded_across_runs: int = 0
    warnings: list[str] = field(default_factory=list)
    #: The rows that are arms (`MODEL @ARM`): label → (model, arm). Arms of a run, and runs
    #: reported with `--arms`, whose arm is the run's path (`ARM @RUN` for both).
    model_arms: dict[str, tuple[str, str]] = field(default_factory=dict)

    def architectures(self) -> list[str]:
        return _unique(split_condition(c)[0] for c in self.conditions)

    def base_models(self) -> list[str]:
        """The models themselves, each once however many arms it ran in (the rows are
        ``MODEL @ARM`` labels)."""
        return _unique(self.model_arms.get(label, (label, ""))[0] for label in self.models)

    def arms(self) -> list[str]:
        """The arms the rows compare (prompt suites, or runs with ``--arms``); none without."""
        return _unique(arm for label in self.models
                       if (arm := self.model_arms.get(label, (label, ""))[1]))

    def obs_modes(self) -> list[str]:
        modes = _unique(split_condition(c)[1] for c in self.conditions)
        return sorted(modes, key=lambda m: (obs_mode_rank(m), m))


def check_run_folder(path: str | Path) -> Path:
    """The path, if it is a run folder; else NotARunFolder with a one-line reason."""
    p = Path(path)
    if not p.exists():
        raise NotARunFolder(f"{p}: no such run folder")
    if not p.is_dir():
        raise NotARunFolder(f"{p}: not a run folder (a file, not a folder)")
    if not (p / RUN_FILE).is_file() and not (p / RESULTS).is_file():
        raise NotARunFolder(f"{p}: not a run folder (no {RUN_FILE} or {RESULTS}; "
                            "make one with `cocobench run --out DIR`)")
    return p


def load_runs(paths: Sequence[str | Path], *, arms: bool = False) -> ReportData:
    """Read and merge the run folders, later runs winning on duplicate episodes. A report
    row (model, condition) takes episodes of several runs only if their settings agree
    (`arms.row_settings`), else `ReportError`; with `arms`, each run's models are labelled
    by the run's path as given (separate rows)."""
    if not paths:
        raise NotARunFolder("no run folder given")
    folders = [check_run_folder(p) for p in paths]
    merged: dict[tuple, tuple[int, dict[str, Any]]] = {}
    row_runs: dict[tuple[str, str], int] = {}  # report row -> the first run with episodes
    model_arms: dict[str, tuple[str, str]] = {}
    runs, models, conditions, across = [], [], [], 0
    for index, path in enumerate(folders):
        info, records = _read_run(path)
        if arms:
            records = {(arm_label(k[0], path), *k[1:]): r for k, r in records.items()}
        # a row's model label -> (model, prompt-suite arm) as the run recorded them
        identity = {k[0]: (r["model"], r.get("arm") or "") for k, r in records.items()}
        model_arms.update({label: (model, _arm(arm, path if arms else None))
                           for label, (model, arm) in identity.items() if arm or arms})
        runs.append(info)
        models += [arm_label(m, path) for m in info.models] if arms else info.models
        conditions += info.conditions
        for row in dict.fromkeys(key[:2] for key in records):
            first = row_runs.setdefault(row, index)
            if first != index:  # (with --arms, rows of two runs never meet)
                _check_same_settings(runs[first], info, *row, *identity[row[0]])
        for key, record in records.items():
            across += key in merged
            merged[key] = (index, record)
            models.append(key[0])
            conditions.append(key[1])
    present_models = {key[0] for key in merged}
    present_conditions = {key[1] for key in merged}
    # plan order first (run.json), then first appearance; only what has episodes
    models = [m for m in _unique(models) if m in present_models]
    conditions = _order_conditions([c for c in _unique(conditions) if c in present_conditions])
    items = sorted(merged.items(), key=lambda kv: (
        models.index(kv[0][0]), conditions.index(kv[0][1]), kv[0][2], kv[0][3]))
    return ReportData(runs=runs, episodes=_columns(items), models=models,
                      conditions=conditions, superseded_across_runs=across,
                      warnings=invalid_line_warnings(runs),
                      model_arms={k: v for k, v in model_arms.items() if k in present_models})


def _arm(arm: str, run: Path | None) -> str:
    """A row's arm: its prompt-suite arm, and its run with `--arms` (``ARM @RUN``)."""
    if run is None:
        return arm
    return arm_label(arm, run) if arm else str(run)


def _check_same_settings(first: RunInfo, other: RunInfo, label: str, condition: str,
                         model: str, arm: str) -> None:
    differ = difference(row_settings(first.record, model, arm),
                        row_settings(other.record, model, arm))
    if differ:
        raise ReportError(
            f"{first.path} and {other.path} both hold {label} {condition} episodes but differ "
            f"in {differ}: report them separately, or pass --arms to make each run its own arm")


def _read_run(path: Path) -> tuple[RunInfo, dict[tuple, dict[str, Any]]]:
    folder = RunFolder(path)
    record: dict[str, Any] = {}
    try:
        if (path / RUN_FILE).exists():
            record = folder.run_record()  # (a folder in its place is named, not skipped)
        scan = folder.scan_results(check_trajectories=True)  # every line validated (pydantic)
    except RunFolderError as exc:  # unreadable, not JSON, a field of the wrong type
        raise NotARunFolder(str(exc)) from None
    records = {(arm_label(k.model, k.arm) if k.arm else k.model, k.condition, k.task_id,
                k.epoch): row for k, row in scan.latest.items()}  # file order of latest lines
    info = RunInfo(
        path=path, name=str(record.get("name") or path.resolve().name), record=record,
        lines=len(scan.rows), torn_tail=scan.torn_tail, episodes=len(records),
        infra_errors=sum(1 for r in records.values() if is_infra_failure(r)),
        invalid_lines=scan.invalid_lines, missing_trajectories=len(scan.missing))
    return info, records


def invalid_line_warnings(runs: Sequence[RunInfo]) -> list[str]:
    """One warning per run with result lines the report skipped (counted, with where)."""
    return [f"{run.path / RESULTS}: {run.invalid_lines} invalid result line"
            f"{'s' if run.invalid_lines != 1 else ''} skipped (not JSON, or not a valid "
            "result: `cocobench run --out RUN --resume` names each and runs its episode again)"
            for run in runs if run.invalid_lines]


def _columns(items: list[tuple[tuple, tuple[int, dict[str, Any]]]]) -> Episodes:
    rows = [record for _, (_, record) in items]
    conds = [key[1] for key, _ in items]
    split = [split_condition(c) for c in conds]
    text = {
        "model": [key[0] for key, _ in items],
        "condition": conds,
        "arch": [a for a, _ in split],
        "obs": [o for _, o in split],
        "task_id": [key[2] for key, _ in items],
        "dim": [str(r.get("dim") or "") for r in rows],
        "failure_kind": [_failure_kind(r) for r in rows],
    }
    numeric = {name: np.array([_number(read(r)) for r in rows], dtype=np.float64)
               for name, read in _NUMERIC.items()}
    return Episodes(
        text={k: np.array(v, dtype=object) for k, v in text.items()},
        numeric=numeric,
        epoch=np.array([key[3] for key, _ in items], dtype=np.int64),
        run_index=np.array([index for _, (index, _) in items], dtype=np.int64))


def _failure_kind(record: Mapping[str, Any]) -> str:
    if record.get("infra_error"):
        return INFRA_KIND
    if is_planner_failure(record):
        return PLANNER_KIND
    kind = record.get("failure_kind")
    if kind is None and record.get("task_success"):
        return "success"
    return str(kind) if kind else UNRECORDED_KIND


def _number(value: Any) -> float:
    if value is None or isinstance(value, str):
        return np.nan
    try:
        return float(value)
    except (TypeError, ValueError):
        return np.nan


def _flag(count: Any) -> float | None:
    number = _number(count)
    return None if np.isnan(number) else float(number > 0)


def _usage(record: Mapping[str, Any], key: str, fallback: Any = None) -> Any:
    usage = record.get("usage")
    if isinstance(usage, Mapping) and usage.get(key) is not None:
        return usage[key]
    return fallback


def _cross(record: Mapping[str, Any], dim: str) -> Any:
    block = (record.get("cross_construct") or {}).get(dim)
    if isinstance(block, Mapping) and block.get("status", "scored") == "scored":
        return block.get("score")
    return None


def _unique(values: Iterable[str]) -> list[str]:
    return list(dict.fromkeys(v for v in values if v is not None))


def _order_conditions(conditions: list[str]) -> list[str]:
    """Architectures in first-seen order, image before blind within each."""
    archs = _unique(split_condition(c)[0] for c in conditions)

    def key(condition: str) -> tuple[int, int, str]:
        arch, obs = split_condition(condition)
        return archs.index(arch), obs_mode_rank(obs), obs

    return sorted(conditions, key=key)
