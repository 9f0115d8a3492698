"""Hostile changes to a real run folder, for the property-based tests of its readers: one
field of a result line, `run.json`, a trajectory or a prompt file set to a value of another
type, nested deep, or a text with `..`, `/`, NUL, a lone surrogate or a code reference (to
the canary planted in the folder, or the canary module); or the whole file replaced by bytes
that are not JSON, or by a folder.

The viewer's fuzz (tests/viewer/test_fuzz_run_folder.py) shares `Deep`, `dumps`,
`every_text` and `field_paths`."""

from __future__ import annotations

import gzip
import json
import shutil
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from hypothesis import strategies as st

from tests.readers.conftest import CANARY_FILE, CANARY_MODULE

#: Replaced, when a mutation is applied, by the run folder's path and by the example's root
#: (a folder above the run whose whole tree the tests check for files written outside).
RUN, ROOT = "{RUN}", "{ROOT}"
CODE_REFERENCES = (
    f"{CANARY_FILE}:build_x_blind", f"{CANARY_FILE}:build_x_image", f"{CANARY_FILE}:build_x",
    f"{RUN}/{CANARY_FILE}:build_x_blind", f"{RUN}/{CANARY_FILE}:NAME",
    f"{CANARY_MODULE}:NAME_blind", f"{CANARY_MODULE}:build_x_image", f"{CANARY_MODULE}:NAME",
    f"{CANARY_MODULE}.build_x",
)
HOSTILE_TEXTS = (
    "..", "../../../../../../ESCAPED", "../../../../../ESCAPED.png", "a/../../ESCAPED", "/",
    "a/b", f"{ROOT}/ESCAPED", f"{ROOT}/ESCAPED.png", "x\x00y", "\x00", "\ud800", "a\udfffb",
    "", " ", "\n", "C0_image", "D1_blind", "greedy", "agent_1", "é🙂", "%2e%2e%2fESCAPED",
    "..\\..\\ESCAPED", "data:image/png;base64,!!!", "data:image/png;base64,AAAA",
)
HUGE_NUMBERS = (10**30, -(10**30), 2**63, -1, 0, 1, 2**31)


@dataclass(frozen=True)
class Deep:
    """A list nested `depth` deep (written as text: too deep for `json.dumps`)."""

    depth: int


DEEP_MARK = "__deep_list__"

leaves = st.one_of(
    st.none(), st.booleans(), st.integers(), st.sampled_from(HUGE_NUMBERS),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from(HOSTILE_TEXTS + CODE_REFERENCES),
    st.text(st.characters(codec=None, exclude_categories=()), max_size=6),
)
values = st.one_of(
    st.recursive(leaves, lambda inner: st.lists(inner, max_size=3)
                 | st.dictionaries(st.sampled_from(HOSTILE_TEXTS) | st.text(max_size=4),
                                   inner, max_size=3), max_leaves=6),
    st.builds(Deep, st.integers(min_value=2, max_value=5000)),
)
#: Whole files that are not what their readers expect.
RAW_FILES = (b"", b"\xff\xfe\x00", b"{", b"[]", b"null", b"7", b'"text"', b"{}\n{}",
             b"\x1f\x8b\x08\x00garbage", b"[" * 3000 + b"]" * 3000, "folder", "missing")


@dataclass(frozen=True)
class Mutation:
    """One change to one file of a run folder."""

    target: str  # "results", "run.json", "trajectory" or "prompts"
    index: int  # which result line / episode (modulo how many there are)
    op: str  # "set", "delete", "every_text" or "raw"
    path: tuple[Any, ...] = ()  # of the field, for "set" and "delete"
    value: Any = None  # the value set, the text of every_text, or the raw file
    appended: bool = False  # a result line changed as a copy appended to the file


def documents(run: Path) -> dict[str, list[Path]]:
    """The files of each target in a run folder, in a fixed order."""
    return {"results": [run / "results.jsonl"], "run.json": [run / "run.json"],
            "trajectory": sorted(run.glob("episodes/**/trajectory.json")),
            "prompts": sorted(run.glob("episodes/**/prompts.json.gz"))}


def field_paths(document: Any, depth: int = 7, items: int = 3) -> list[tuple[Any, ...]]:
    """The paths of the fields of a JSON document, `depth` keys deep at most (lists: their
    first `items` items)."""
    out: list[tuple[Any, ...]] = []

    def walk(value: Any, path: tuple[Any, ...]) -> None:
        if path:
            out.append(path)
        if len(path) >= depth:
            return
        if isinstance(value, dict):
            for key, item in value.items():
                walk(item, (*path, key))
        elif isinstance(value, list):
            for index, item in enumerate(value[:items]):
                walk(item, (*path, index))

    walk(document, ())
    return out


def mutations(run: Path) -> st.SearchStrategy[Mutation]:
    """Every kind of change to the run folder at `run` (its documents read once)."""
    files = documents(run)
    paths = {target: field_paths(json.loads(_result_lines(found[0])[0]) if target == "results"
                                 else _read(target, found[0]))
             for target, found in files.items()}

    def of(target: str) -> st.SearchStrategy[Mutation]:
        index = st.integers(min_value=0, max_value=7)
        return st.one_of(
            st.builds(Mutation, st.just(target), index, st.just("set"),
                      st.sampled_from(paths[target]), values, st.booleans()),
            # a code reference in one field (a condition, a planner, a model, …)
            st.builds(Mutation, st.just(target), index, st.just("set"),
                      st.sampled_from(paths[target]),
                      st.sampled_from(CODE_REFERENCES) | st.lists(
                          st.sampled_from(CODE_REFERENCES), min_size=1, max_size=2),
                      st.booleans()),
            st.builds(Mutation, st.just(target), index, st.just("delete"),
                      st.sampled_from(paths[target]), st.none(), st.booleans()),
            st.builds(Mutation, st.just(target), index, st.just("every_text"), st.just(()),
                      st.sampled_from(HOSTILE_TEXTS + CODE_REFERENCES), st.booleans()),
            st.builds(Mutation, st.just(target), index, st.just("raw"), st.just(()),
                      st.sampled_from(RAW_FILES)),
        )

    return st.one_of(*(of(target) for target in files))


def apply(mutation: Mutation, run: Path, root: Path) -> None:
    """Make `mutation` in the run folder at `run` (`root`: what `{ROOT}` stands for)."""
    found = documents(run)[mutation.target]
    path = found[mutation.index % len(found)]
    places = {RUN: str(run), ROOT: str(root)}
    if mutation.op == "raw" and not isinstance(mutation.value, bytes):
        _replace_file(path, mutation.value)  # a folder in its place, or no file
        return
    if mutation.target == "results":
        lines = _result_lines(path)
        number = mutation.index % len(lines)
        changed = _changed(mutation, lines[number], places)
        if mutation.appended:
            lines.append(changed)
        else:
            lines[number] = changed
        path.write_bytes(b"".join(line + b"\n" for line in lines))
        return
    if mutation.op == "raw":
        _replace_file(path, mutation.value)
        return
    data = _changed(mutation, _read(mutation.target, path), places)
    path.write_bytes(gzip.compress(data) if mutation.target == "prompts" else data)


def _changed(mutation: Mutation, document: Any, places: dict[str, str]) -> bytes:
    """The document's bytes after the mutation (raw bytes for a result line's "raw")."""
    if isinstance(document, bytes):
        document = json.loads(document)
    if mutation.op == "raw":
        return mutation.value
    if mutation.op == "every_text":
        document = every_text(document, _placed(mutation.value, places))
    else:
        document = _at(document, mutation.path, mutation.op, _placed(mutation.value, places))
    return dumps(document)


def _at(document: Any, path: tuple[Any, ...], op: str, value: Any) -> Any:
    """The document with the field at `path` set or deleted (the paths are those of the
    first file of its kind: where another lacks the field's parent, its top level is)."""
    parent = document
    for part in path[:-1]:
        try:
            parent = parent[part]
        except (KeyError, IndexError, TypeError):
            parent, path = document, (path[-1],)
            break
    if not isinstance(parent, (dict, list)) or (isinstance(parent, list)
                                                 and not isinstance(path[-1], int)):
        return value if op == "set" else document
    if isinstance(parent, list) and path[-1] >= len(parent):
        return document
    if op == "delete":
        if isinstance(parent, list) or path[-1] in parent:
            del parent[path[-1]]
    else:
        parent[path[-1]] = value
    return document


def every_text(value: Any, text: str) -> Any:
    """`value` with every text in it (not a key) replaced by `text`."""
    if isinstance(value, str):
        return text
    if isinstance(value, list):
        return [every_text(item, text) for item in value]
    if isinstance(value, dict):
        return {key: every_text(item, text) for key, item in value.items()}
    return value


def _placed(value: Any, places: dict[str, str]) -> Any:
    if isinstance(value, str):
        for mark, place in places.items():
            value = value.replace(mark, place)
        return value
    if isinstance(value, list):
        return [_placed(item, places) for item in value]
    if isinstance(value, dict):
        return {_placed(k, places): _placed(v, places) for k, v in value.items()}
    return value


def dumps(document: Any) -> bytes:
    """JSON as Python writes it (NaN, lone surrogates as escapes), deep lists spliced in."""
    deep: list[Deep] = []

    def mark(value: Any) -> Any:
        if isinstance(value, Deep):
            deep.append(value)
            return f"{DEEP_MARK}{len(deep) - 1}"
        if isinstance(value, list):
            return [mark(item) for item in value]
        if isinstance(value, dict):
            return {key: mark(item) for key, item in value.items()}
        return value

    text = json.dumps(mark(document))
    for number, item in enumerate(deep):
        text = text.replace(f'"{DEEP_MARK}{number}"', "[" * item.depth + "]" * item.depth)
    return text.encode("utf-8")


def _replace_file(path: Path, raw: bytes | str) -> None:
    if raw == "missing":
        path.unlink()
    elif raw == "folder":
        path.unlink()
        path.mkdir()
        (path / "inside").write_text("{}")
    else:
        path.write_bytes(raw)


def _read(target: str, path: Path) -> Any:
    raw = path.read_bytes()
    return json.loads(gzip.decompress(raw) if target == "prompts" else raw)


def _result_lines(path: Path) -> list[bytes]:
    return [line for line in path.read_bytes().split(b"\n") if line]


def tree(root: Path) -> dict[str, tuple[int, int]]:
    """Every file under `root` (relative path → size, mtime): to see what was written."""
    out = {}
    for path in _walk(root):
        stat = path.lstat()
        out[str(path.relative_to(root))] = (stat.st_size, stat.st_mtime_ns)
    return out


def _walk(root: Path) -> Iterator[Path]:
    for path in root.rglob("*"):
        if path.is_file() or path.is_symlink():
            yield path


def fresh(root: Path) -> None:
    """Empty `root` (an example's folder) for the next example."""
    if root.exists():
        shutil.rmtree(root)
    root.mkdir(parents=True)
