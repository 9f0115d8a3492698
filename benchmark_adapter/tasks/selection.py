"""Choosing which loaded tasks to evaluate: eval sets and filters (reference §3).

An eval-set name is looked up, in order, in `by_cell`, `by_dim`, `by_family`, `curated`, and
finally as a literal task id; the tasks of all names are concatenated and de-duplicated in
order. No name selects every task. The `only_*`, `task_ids` and `limit` filters apply after.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from .config import TaskConfig
from .errors import TaskConfigError
from .loading import file_kind, read_json

CATEGORIES = ("by_cell", "by_dim", "by_family", "curated")

EvalSets = dict[str, dict[str, list[str]]]
# An index dict, an `eval_sets` dict, a subset dict, a path to an index or subset file, or a
# list of any of these.
IndexSource = Mapping[str, Any] | str | Path | Sequence[Any]


def eval_sets_of(tasks: Iterable[TaskConfig]) -> EvalSets:
    """`by_cell`/`by_dim`/`by_family` sets built from loaded tasks (ids sorted, as in index.json).

    `curated` is empty: curated subsets only come from index or subset files.
    """
    sets: EvalSets = {category: {} for category in CATEGORIES}
    for task in tasks:
        sets["by_cell"].setdefault(task.cell, []).append(task.task_id)
        sets["by_dim"].setdefault(task.coordination_dim, []).append(task.task_id)
        sets["by_family"].setdefault(task.task_family, []).append(task.task_id)
    for category in sets.values():
        for name in category:
            category[name] = sorted(set(category[name]))
    return {category: dict(sorted(named.items())) for category, named in sets.items()}


def select_tasks(
    tasks: Sequence[TaskConfig],
    eval_sets: str | Iterable[str] = (),
    *,
    index: IndexSource | None = None,
    only_cell: str | None = None,
    only_family: str | None = None,
    only_dim: str | None = None,
    task_ids: str | Iterable[str] = (),
    limit: int = 0,
) -> list[TaskConfig]:
    """The tasks to run, in selection order.

    `eval_sets` names (comma-separated names are split) are resolved against the sets derived
    from `tasks`, overlaid with those of `index` (see `IndexSource`). Ids a set lists but that
    were not loaded are ignored. An unknown name, or a `task_ids` entry that is not a loaded
    task, raises `TaskConfigError`. `limit <= 0` means no limit.
    """
    names = _names(eval_sets)
    chosen = _resolve_eval_sets(tasks, names, _merged_sets(tasks, index)) if names else list(tasks)
    chosen = _filter(chosen, only_cell, only_family, only_dim)
    chosen = _filter_ids(tasks, chosen, _names(task_ids))
    return chosen[:limit] if limit > 0 else chosen


# -- eval-set resolution -----------------------------------------------------------------


def _names(value: str | Iterable[str]) -> list[str]:
    """Names from a string or list; commas separate names too (as on the reference CLI)."""
    items = [value] if isinstance(value, str) else list(value)
    return [part.strip() for item in items for part in str(item).split(",") if part.strip()]


def _resolve_eval_sets(
    tasks: Sequence[TaskConfig], names: list[str], sets: EvalSets
) -> list[TaskConfig]:
    by_id = {task.task_id: task for task in tasks}
    chosen: dict[str, TaskConfig] = {}  # insertion order = selection order, keys dedupe
    for name in names:
        for tid in _ids_for(name, sets, by_id):
            if tid in by_id:
                chosen.setdefault(tid, by_id[tid])
    return list(chosen.values())


def _ids_for(name: str, sets: EvalSets, by_id: Mapping[str, TaskConfig]) -> list[str]:
    for category in CATEGORIES:
        if name in sets[category]:
            return sets[category][name]
    if name in by_id:
        return [name]
    known = "; ".join(
        f"{category}: {', '.join(sets[category])}" for category in CATEGORIES if sets[category]
    )
    raise TaskConfigError(
        "eval_sets", f"unknown eval set or task id {name!r} ({known or 'no sets'})"
    )


def _merged_sets(tasks: Sequence[TaskConfig], index: IndexSource | None) -> EvalSets:
    """Sets derived from the tasks, with any named by `index` taking precedence."""
    sets = eval_sets_of(tasks)
    for category, named in (_sets_from_index(index) if index is not None else {}).items():
        sets[category].update(named)
    return sets


def _sets_from_index(source: IndexSource, name: str | None = None) -> EvalSets:
    """The eval sets an index-like source defines."""
    if isinstance(source, (str, Path)):
        return _sets_from_index(read_json(source), Path(source).stem)
    if isinstance(source, Mapping):
        return _sets_from_mapping(source, name)
    if isinstance(source, Sequence):
        return _merge([_sets_from_index(item) for item in source])
    raise TaskConfigError("index", f"cannot read eval sets from a {type(source).__name__}")


def _sets_from_mapping(data: Mapping[str, Any], name: str | None) -> EvalSets:
    if file_kind(data) == "subset":
        subset_name = str(data.get("name") or name or "subset")
        return {"curated": {subset_name: [str(t) for t in data["task_ids"]]}}
    sets = data.get("eval_sets", data)
    if not isinstance(sets, Mapping) or not _has_categories(sets):
        raise TaskConfigError(
            name or "index", "no eval sets here (expected eval_sets, by_cell… or task_ids)"
        )
    return {c: {k: list(v) for k, v in sets[c].items()} for c in CATEGORIES if c in sets}


def _has_categories(sets: Mapping[str, Any]) -> bool:
    return any(isinstance(sets.get(category), Mapping) for category in CATEGORIES)


def _merge(parts: list[EvalSets]) -> EvalSets:
    merged: EvalSets = {}
    for part in parts:
        for category, named in part.items():
            merged.setdefault(category, {}).update(named)
    return merged


# -- filters -----------------------------------------------------------------------------


def _filter(
    tasks: list[TaskConfig], cell: str | None, family: str | None, dim: str | None
) -> list[TaskConfig]:
    return [
        t
        for t in tasks
        if (not cell or t.cell == cell)
        and (not family or t.task_family == family)
        and (not dim or t.coordination_dim == dim)
    ]


def _filter_ids(
    loaded: Sequence[TaskConfig], chosen: list[TaskConfig], ids: list[str]
) -> list[TaskConfig]:
    if not ids:
        return chosen
    # An id that names no loaded task is a typo; one merely outside the selection is not.
    unknown = sorted(set(ids) - {t.task_id for t in loaded})
    if unknown:
        raise TaskConfigError("task_ids", f"no loaded task has id {', '.join(unknown)}")
    wanted = set(ids)
    return [t for t in chosen if t.task_id in wanted]
