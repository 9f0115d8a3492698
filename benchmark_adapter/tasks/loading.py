"""Loading task configs from a file, a folder tree, an index, a subset file or a built-in suite.

Sources understood by `load_tasks` (reference §3):

* one task-config file;
* a folder tree: every `*.json` below it, sorted by relative path; index and subset files and
  JSON that is plainly not a task config are skipped, as is `family_goal_and_skill_pool.json`;
* the reference `task_config/index.json`: `instances[].config` paths;
* a subset file such as `subsets/rep240.json`: `task_ids`, looked up in the config tree of the
  subset file's grandparent folder;
* a built-in suite name: a folder `benchmark_adapter/data/<name>/`.
"""

from __future__ import annotations

import json
import os
import re
import sys
import warnings
from collections.abc import Iterable, Iterator
from importlib import resources
from pathlib import Path
from typing import Any, Literal

from pydantic import ValidationError

from .checks import problems
from .config import TaskConfig
from .errors import TaskConfigError, from_json_error, from_validation_error

Missing = Literal["error", "skip"]


class MissingTasksWarning(UserWarning):
    """Tasks an index or subset file lists were not found and were skipped (`missing="skip"`)."""


# The reference keeps a non-instance file beside the configs; all its loaders skip it.
POOL_FILE = "family_goal_and_skill_pool.json"

# Keys only a task config has at top level; one of them is enough to call a file a config.
_CONFIG_KEYS = frozenset(
    {"task_id", "coordination_dim", "task_family", "init_state", "goal_predicates", "agents"}
)

# How many missing ids an error message shows before eliding the rest.
_SHOWN_IDS = 5

# Deeper JSON than this is not a config (real ones nest 5 levels); refusing it here keeps
# every later reader and writer of the data clear of Python's recursion limit.
MAX_JSON_DEPTH = 64

# Where a lone surrogate can come from: the file was read as strict UTF-8, so only a JSON
# escape of one (a pair's escapes decode to one valid character, and pass).
_SURROGATE_ESCAPE = re.compile(r"\\u[dD][89a-fA-F][0-9a-fA-F]{2}")


# -- public API --------------------------------------------------------------------------


def load_task(path: str | Path) -> TaskConfig:
    """Load and validate one task-config file; the result remembers its `source`."""
    path = Path(path)
    return _parse(read_json(path), path)


def load_tasks(source: str | Path, *, missing: Missing = "error") -> list[TaskConfig]:
    """Load every task a source describes (file, folder, index, subset file or suite name).

    `missing` applies to index and subset files: `"error"` (default) raises when listed tasks
    cannot be found, `"skip"` keeps the ones found and issues a `MissingTasksWarning` saying
    which were skipped. Duplicated task ids are always an error.
    """
    if missing not in ("error", "skip"):
        raise ValueError(f"missing must be 'error' or 'skip', not {missing!r}")
    path = _resolve_source(source)
    tasks = _load_tree(path) if path.is_dir() else _load_file(path, missing)
    _check_unique(tasks)
    return tasks


def available_suites() -> list[str]:
    """Names of the built-in suites (folders under `benchmark_adapter/data/`)."""
    root = _suites_root()
    if not root.is_dir():
        return []
    return sorted(
        p.name for p in root.iterdir() if p.is_dir() and not p.name.startswith(("_", "."))
    )


def read_json(path: str | Path) -> Any:
    """Parse a JSON file, turning I/O, encoding, syntax and nesting problems into
    `TaskConfigError`."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except OSError as exc:
        raise TaskConfigError(path, f"cannot read file: {exc.strerror or exc}") from exc
    except UnicodeDecodeError as exc:
        raise TaskConfigError(
            path, f"not UTF-8 text (byte 0x{exc.object[exc.start]:02x} at offset {exc.start})"
        ) from None
    too_long: list[str] = []
    try:
        data = _decode(path, text)
    except TaskConfigError:  # a ValueError too, and final: a bad file is decoded once
        raise
    except ValueError:  # an integer longer than Python converts: decoded again to name it
        data = _decode(path, text, parse_int=lambda literal: _integer(literal, too_long))
    # Nesting needs an opening bracket per level: a file with few (a task config has about
    # 30, inside strings included) cannot nest too deep, and is not walked.
    if text.count("[") + text.count("{") > MAX_JSON_DEPTH and depth_exceeds(data,
                                                                          MAX_JSON_DEPTH):
        raise _too_deep(path)
    if too_long:
        _refuse_long_integers(path, data)
    if _SURROGATE_ESCAPE.search(text):
        _refuse_lone_surrogates(path, data)
    return data


def _decode(path: str | Path, text: str, **options: Any) -> Any:
    """`json.loads`, its syntax errors and Python's recursion limit as `TaskConfigError`; a
    too-long integer's `ValueError` passes (decoding each integer through `_integer` instead
    costs a sixth of the decoding: the common case does not)."""
    try:
        return json.loads(text, **options)
    except json.JSONDecodeError as exc:
        raise from_json_error(path, exc) from exc
    except RecursionError:  # deeper than Python's own limit
        raise _too_deep(path) from None


def _refuse_lone_surrogates(path: str | Path, data: Any) -> None:
    """Refuse text that is not Unicode: a JSON escape of half a surrogate pair (``\\ud800``)
    decodes to a string that no UTF-8 file (a trajectory, a result line) can hold, so an
    episode of it could not be recorded."""
    for value, where in _every_key_and_value(data):
        if isinstance(value, str):
            _check_text(path, value, where)


def _every_key_and_value(data: Any) -> Iterator[tuple[Any, tuple[str, ...]]]:
    """Each value of `data` (itself included) and each object's key, with the field it is in
    (a key: its object's); iterative, an object's keys given when the object is."""
    stack: list[tuple[Any, tuple[str, ...]]] = [(data, ())]
    while stack:
        value, where = stack.pop()
        yield value, where
        if isinstance(value, dict):
            for key, child in value.items():
                yield key, where
                stack.append((child, (*where, str(key))))
        elif isinstance(value, list):
            stack.extend((child, (*where, str(i))) for i, child in enumerate(value))


def _check_text(path: str | Path, text: str, where: tuple[str, ...]) -> None:
    try:
        text.encode("utf-8")
    except UnicodeEncodeError as exc:
        lone = f"\\u{ord(text[exc.start]):04x}"
        raise TaskConfigError(path, f"not valid UTF-8 text: a lone surrogate ({lone}, from a "
                                    "JSON escape) that no run folder can record",
                              ".".join(where) or None) from None


class _LongInteger(str):
    """An integer literal longer than Python converts (`sys.get_int_max_str_digits`), kept
    as its text until `_refuse_long_integers` names its field."""


def _integer(literal: str, too_long: list[str]) -> int | str:
    """`json.loads`'s `parse_int`: the integer, or a `_LongInteger` (noted in `too_long`)
    where converting it would raise deep inside the JSON decoder."""
    limit = sys.get_int_max_str_digits()
    if limit and len(literal.lstrip("-")) > limit:
        too_long.append(literal)
        return _LongInteger(literal)
    return int(literal)


def _refuse_long_integers(path: str | Path, data: Any) -> None:
    """Refuse the first `_LongInteger` of `data`, naming its field."""
    for value, where in _every_key_and_value(data):
        if isinstance(value, _LongInteger):
            raise TaskConfigError(path, f"an integer of {len(value.lstrip('-'))} digits "
                                        f"(Python converts at most "
                                        f"{sys.get_int_max_str_digits()})",
                                  ".".join(where) or None)


def _too_deep(path: str | Path) -> TaskConfigError:
    return TaskConfigError(path, f"JSON nested more than {MAX_JSON_DEPTH} levels deep")


def file_kind(data: Any) -> str | None:
    """What a parsed JSON file is: `"index"`, `"subset"`, `"task"`, or None (none of these)."""
    if not isinstance(data, dict):
        return None
    if isinstance(data.get("instances"), list):
        return "index"
    if isinstance(data.get("task_ids"), list):
        return "subset"
    if _CONFIG_KEYS & data.keys():
        return "task"
    return None


def depth_exceeds(data: Any, limit: int) -> bool:
    """Whether arrays/objects (mappings/lists) nest more than `limit` levels (iterative: no
    recursion). Walked a level at a time, each level's containers gathered by comprehensions
    (a config's 900 files: a quarter of the time of a node-by-node walk). A YAML config's
    aliases share nodes: a node met twice on one level is kept once, so that sharing neither
    hides its depth nor makes the walk exponential (at most `limit` levels of distinct
    nodes)."""
    level = [data] if isinstance(data, (dict, list)) else []
    for _ in range(limit):
        children = [child for value in level
                    for child in (value.values() if isinstance(value, dict) else value)]
        level = list({id(child): child for child in children
                      if isinstance(child, (dict, list))}.values())
        if not level:
            return False
    return True


# -- sources -----------------------------------------------------------------------------


def _suites_root() -> Path:
    """The folder holding the built-in suites (tests monkeypatch this)."""
    return Path(str(resources.files("benchmark_adapter") / "data"))


def _resolve_source(source: str | Path) -> Path:
    """An existing path as given, else a built-in suite folder for a bare name."""
    path = Path(source)
    if path.exists():
        return path
    text = str(source)
    if _is_bare_name(text):
        return _suite_path(text)
    raise TaskConfigError(source, "no such file or folder")


def _is_bare_name(text: str) -> bool:
    # A path-looking string that doesn't exist is a typo, not a suite name.
    separators = {"/", os.sep} | ({os.altsep} if os.altsep else set())
    return bool(text) and not (separators & set(text)) and not text.endswith(".json")


def _suite_path(name: str) -> Path:
    folder = _suites_root() / name
    if folder.is_dir() and name in available_suites():
        return folder
    suites = ", ".join(available_suites()) or "none"
    raise TaskConfigError(
        name, f"not a file, folder or built-in suite (available suites: {suites})"
    )


def _load_file(path: Path, missing: Missing) -> list[TaskConfig]:
    """One file: dispatch on what it contains."""
    data = read_json(path)
    kind = file_kind(data)
    if kind == "index":
        return _load_index(path, data, missing)
    if kind == "subset":
        return _load_subset(path, data, missing)
    return [_parse(data, path)]


def _load_tree(root: Path) -> list[TaskConfig]:
    """Every task config under `root`, in relative-path order."""
    tasks = []
    for path in _json_files(root):
        data = read_json(path)
        if file_kind(data) == "task":
            tasks.append(_parse(data, path))
    return tasks


def _json_files(root: Path) -> list[Path]:
    files = (p for p in root.rglob("*.json") if p.name != POOL_FILE and p.is_file())
    return sorted(files, key=lambda p: p.relative_to(root).as_posix())


def _load_index(path: Path, data: dict[str, Any], missing: Missing) -> list[TaskConfig]:
    """The configs an index lists, in index order."""
    tasks, absent = [], []
    for i, record in enumerate(data["instances"]):
        config = _index_config_path(path, record, i)
        if config is None:
            absent.append(str(record.get("task_id") or record["config"]))
        else:
            tasks.append(load_task(config))
    _report_missing(path, "instances", absent, len(data["instances"]), path.parent.parent, missing)
    return tasks


def _index_config_path(index: Path, record: Any, i: int) -> Path | None:
    """Where an index record's config lives, or None if it is not on disk."""
    if not isinstance(record, dict) or not isinstance(record.get("config"), str):
        raise TaskConfigError(index, "expected an object with a 'config' path", f"instances.{i}")
    # Reference paths are relative to the repository folder holding `task_config/`; hand-made
    # indexes often use paths relative to the index itself.
    for base in (index.parent.parent, index.parent):
        candidate = base / record["config"]
        if candidate.is_file():
            return candidate
    return None


def _load_subset(path: Path, data: dict[str, Any], missing: Missing) -> list[TaskConfig]:
    """The configs a subset file names, in subset order, found under its grandparent."""
    wanted = list(dict.fromkeys(str(t) for t in data["task_ids"]))
    root = path.parent.parent
    found = _find_ids(root, set(wanted))
    absent = [tid for tid in wanted if tid not in found]
    _report_missing(path, "task_ids", absent, len(wanted), root, missing)
    return [found[tid] for tid in wanted if tid in found]


def _find_ids(root: Path, wanted: set[str]) -> dict[str, TaskConfig]:
    """Load the configs of `wanted` ids under `root`.

    Files are named `<task_id>.json` in the reference, so those are tried first; the rest of
    the tree is only opened when some ids are still unaccounted for.
    """
    files = _json_files(root)
    by_name = [p for p in files if p.stem in wanted]
    found = {t.task_id: t for t in map(load_task, by_name) if t.task_id in wanted}
    if len(found) < len(wanted):
        others = (p for p in files if p not in by_name)
        found.update(_scan_for_ids(others, wanted - found.keys()))
    return found


def _scan_for_ids(paths: Iterable[Path], wanted: set[str]) -> dict[str, TaskConfig]:
    found = {}
    for path in paths:
        data = read_json(path)
        if file_kind(data) == "task" and data.get("task_id") in wanted:
            found[data["task_id"]] = _parse(data, path)
    return found


def _report_missing(
    path: Path, field: str, absent: list[str], total: int, root: Path, missing: Missing
) -> None:
    if not absent:
        return
    shown = ", ".join(absent[:_SHOWN_IDS]) + (", …" if len(absent) > _SHOWN_IDS else "")
    what = f"{len(absent)} of {total} tasks not found under {root} (e.g. {shown})"
    if missing == "skip":
        warnings.warn(MissingTasksWarning(f"{path}: {field}: {what}; skipped them"),
                      stacklevel=5)  # load_tasks' caller
        return
    raise TaskConfigError(
        path, f"{what}; skip them with --missing skip (missing='skip' in Python)", field
    )


# -- validation --------------------------------------------------------------------------


def _parse(data: Any, path: Path) -> TaskConfig:
    """Validate parsed JSON as a `TaskConfig` from `path`."""
    kind = file_kind(data)
    if kind != "task":
        raise TaskConfigError(path, _not_a_config(data, kind))
    try:
        task = TaskConfig.model_validate(data)
    except ValidationError as exc:
        raise from_validation_error(path, exc) from None
    found = problems(task)
    if found:
        (field, what), more = found[0], len(found) - 1
        if more:
            what += f" (and {more} more problem{'s' if more > 1 else ''})"
        raise TaskConfigError(path, what, field)
    task._source = str(path)
    return task


def _not_a_config(data: Any, kind: str | None) -> str:
    if kind in ("index", "subset"):
        return f"this is an eval-set {kind} file, not a task config; use load_tasks() on it"
    if isinstance(data, dict):
        return "not a task config (no task_id, init_state, agents or goal_predicates key)"
    return f"not a task config: expected a JSON object, got a JSON {_json_type(data)}"


def _json_type(data: Any) -> str:
    names = {list: "array", str: "string", bool: "boolean", type(None): "null"}
    return names.get(type(data), "number")


def _check_unique(tasks: list[TaskConfig]) -> None:
    """Two configs with one task id would silently shadow each other in every later lookup;
    ids differing only in case would share one episode folder on case-insensitive disks."""
    seen: dict[str, TaskConfig] = {}
    for task in tasks:
        other = seen.setdefault(task.task_id.casefold(), task)
        if other is task:
            continue
        what = (f"duplicated task id {task.task_id!r}" if other.task_id == task.task_id
                else f"task id {task.task_id!r} differs only in case from {other.task_id!r}")
        raise TaskConfigError(
            task.source or task.task_id, f"{what}, also defined in {other.source}", "task_id"
        )
