"""The viewer against generated run folders (issue 34's acceptance): a real run folder whose
result lines, `run.json`, trajectories and prompts are mutated field by field (types,
nesting, `..`, `/`, NUL, lone surrogates, code references in string fields), served live at
every route and exported with `cocobench view --export`. Never a 5xx, never a traceback,
exit 0 or 2, nothing written outside the export folder, and the canaries (a `.py` file in the
run folder that a code reference names, a module on `sys.path`) never run."""

from __future__ import annotations

import contextlib
import copy
import gzip
import io
import itertools
import json
import logging
import os
import shutil
import sys
import urllib.parse
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cocobench_agents.cli import main
from cocobench_agents.viewer.errors import ViewerError
from cocobench_agents.viewer.local_server import LOG
from cocobench_agents.viewer.pages import Pages
from cocobench_agents.viewer.server import ViewerServer
from cocobench_agents.viewer.source import Catalog
from tests.readers.mutations import Deep, dumps, every_text, field_paths

from .conftest import TASKS
from .hostile import send
from .test_pages import listed

#: What a canary writes when it runs, in the folder the test names.
CANARY = """
from pathlib import Path
Path({mark!r}).write_text("ran")
def build_x(): raise SystemExit("never")
NAME = None
"""
#: A nesting deeper than any JSON reader recurses.
DEEP = Deep(100_000)
#: How far below the examples' common folder each example lives: `..` repeated fewer times
#: than this stays inside it, where the test can see what was written.
NESTING = ("a", "b", "c", "d", "e", "f", "g", "h", "i", "j")
EXAMPLES = itertools.count()
#: Examples per test run (more for a longer hunt: COCOBENCH_FUZZ_EXAMPLES=1000).
EXAMPLES_PER_RUN = int(os.environ.get("COCOBENCH_FUZZ_EXAMPLES", "60"))


@dataclass(frozen=True)
class Base:
    """The real run every example starts from, and where the examples live."""

    run: Path
    examples: Path  # every example's folder is made below it, `NESTING` deep
    marks: tuple[Path, ...]  # what the canaries write if they ever run


@pytest.fixture(scope="module")
def base(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Base]:
    """A greedy run of one instance under C0_image and D1_blind, with a saved frame, and
    canaries: `code/canary.py` in the run folder, `canary_mod` on `sys.path`."""
    root = tmp_path_factory.mktemp("fuzz")
    run = root / "run"
    assert main(["run", "--model", "greedy", "--conditions", "C0_image,D1_blind",
                 "--task-id", TASKS[0], "--out", str(run)]) == 0
    (run / "episodes" / "frame.png").write_bytes(b"\x89PNG a frame")
    for line in lines_of(run):
        path = run / line["trajectory"]
        document = json.loads(path.read_text())
        document["trajectory"][1]["image"] = "episodes/frame.png"
        path.write_text(json.dumps(document))
    marks = (root / "RAN-file.txt", root / "RAN-module.txt")
    (run / "code").mkdir()
    (run / "code" / "canary.py").write_text(CANARY.format(mark=str(marks[0])))
    site = root / "site-packages"
    site.mkdir()
    (site / "canary_mod.py").write_text(CANARY.format(mark=str(marks[1])))
    sys.path.insert(0, str(site))
    try:
        yield Base(run, root.joinpath("examples", *NESTING), marks)
    finally:
        sys.path.remove(str(site))
        sys.modules.pop("canary_mod", None)


class Tracebacks(logging.Handler):
    """Keeps every record logged with an exception (a handler's traceback)."""

    def __init__(self) -> None:
        super().__init__(logging.DEBUG)
        self.records: list[logging.LogRecord] = []

    def emit(self, record: logging.LogRecord) -> None:
        if record.exc_info:
            self.records.append(record)


@pytest.fixture(scope="module")
def tracebacks() -> Iterator[Tracebacks]:
    handler = Tracebacks()
    for name in (LOG.name, "aiohttp"):
        logging.getLogger(name).addHandler(handler)
    try:
        yield handler
    finally:
        for name in (LOG.name, "aiohttp"):
            logging.getLogger(name).removeHandler(handler)


def lines_of(run: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in (run / "results.jsonl").read_text().splitlines()]


# -- mutations -------------------------------------------------------------------------------


def code_references(run: Path) -> list[str]:
    """Conditions and planners naming the canaries, as a hostile run folder would."""
    canary = run / "code" / "canary.py"
    return [f"{canary}:build_x_blind", f"{canary}:build_x", "code/canary.py:build_x_blind",
            "x/code/canary.py:build_x_blind", "canary_mod:build_x_blind", "canary_mod:NAME",
            "canary_mod:NAME_image", "canary_mod"]


def hostile_text(run: Path) -> st.SearchStrategy[str]:
    return st.one_of(
        st.sampled_from(code_references(run)),
        st.sampled_from(["", ".", "..", "../" * 9 + "ESCAPED", "/tmp/ESCAPED-ABSOLUTE", "a/b",
                         "x\x00y", "\ud800", "a\udfffb", "%2e%2e%2fESCAPED", "C:\\ESCAPED",
                         "<script>alert(1)</script>", "data:image/svg+xml,<svg/>",
                         "episodes/../../ESCAPED.png", "episodes/frame.png", "x" * 3000,
                         "agent_1", "D1", "greedy"]),
        st.text(max_size=12))


def values(run: Path) -> st.SearchStrategy[Any]:
    scalars = st.one_of(st.none(), st.booleans(), st.integers(-(10**30), 10**30),
                        st.floats(allow_nan=True), hostile_text(run), st.just(DEEP))
    return st.recursive(scalars, lambda inner: st.one_of(
        st.lists(inner, max_size=3), st.dictionaries(hostile_text(run), inner, max_size=3)),
        max_leaves=6)


def set_at(document: Any, path: tuple[Any, ...], value: Any) -> None:
    for key in path[:-1]:
        document = document[key]
    document[path[-1]] = value


class Mutated:
    """A file of the run (relative to it) with its new content; `what` says what changed
    (a failing example is reported by it, not by the whole content)."""

    def __init__(self, file: str, what: tuple[str, ...], content: Any) -> None:
        self.file, self.what, self.content = file, what, content

    def __repr__(self) -> str:
        return f"Mutated({self.file!r}, {self.what!r})"


@st.composite
def mutated(draw: st.DrawFn, run: Path) -> list[Mutated]:
    """One to three mutations of the run's files, each file with its new content."""
    lines = lines_of(run)
    files: dict[str, Any] = {"results.jsonl": lines,
                             "run.json": json.loads((run / "run.json").read_text())}
    for line in lines:
        files[line["trajectory"]] = json.loads((run / line["trajectory"]).read_text())
        prompts = str(Path(line["trajectory"]).parent / "prompts.json.gz")
        files[prompts] = json.loads(gzip.decompress((run / prompts).read_bytes()))
    changed: dict[str, list[str]] = {}
    for _ in range(draw(st.integers(1, 3))):
        name = draw(st.sampled_from(sorted(files)))
        document = files[name]
        kind = draw(st.sampled_from(["set", "set", "set", "strings", "append"]))
        if kind == "append" and name == "results.jsonl":
            line = copy.deepcopy(draw(st.sampled_from(lines)))
            path = draw(st.sampled_from(field_paths(line, 3, items=4)))
            value = draw(values(run))
            set_at(line, path, value)
            document.append(line)
            what = f"a line appended with {path} = {value!r:.200}"
        elif kind == "strings":
            ref = draw(st.sampled_from(code_references(run)))
            if name == "results.jsonl":
                index = draw(st.integers(0, len(document) - 1))
                document[index] = every_text(document[index], ref)
            else:
                files[name] = every_text(document, ref)
            what = f"every string = {ref!r}"
        else:
            path = draw(st.sampled_from(field_paths(document, 6, items=4)))
            value = draw(values(run))
            set_at(document, path, value)
            what = f"{path} = {value!r:.200}"
        changed.setdefault(name, []).append(what)
    return [Mutated(name, tuple(whats), files[name]) for name, whats in changed.items()]


def write(run: Path, name: str, content: Any) -> None:
    if name == "results.jsonl":
        (run / name).write_bytes(b"".join(dumps(line) + b"\n" for line in content))
    elif name.endswith(".gz"):
        (run / name).write_bytes(gzip.compress(dumps(content)))
    else:
        (run / name).write_bytes(dumps(content))


# -- what the viewer must do ------------------------------------------------------------------


def serve_every_route(run: Path) -> None:
    """Every route of a live viewer of `run`: no answer is a 5xx."""
    try:
        pages = Pages.create(Catalog([run]), live=True)
    except ViewerError:
        return  # `cocobench view` says it in one line (exit 2: checked with --export)
    with ViewerServer(pages, 0) as server:
        index = send(server.port, "/")
        assert index.status == 200, index.raw[-500:]
        targets = ["/index.html", "/api/rows", "/api/rows?since=0", "/static/viewer.js",
                   "/files/0/run.json", "/files/0/episodes/frame.png", "/nope.html"]
        for row in listed(index.raw.partition(b"\r\n\r\n")[2].decode()):
            targets += ["/" + urllib.parse.quote(row["h"]), "/" + urllib.parse.quote(row["c"])]
        for target in targets:
            answer = send(server.port, target)
            assert answer.status < 500, (target, answer.raw[-500:])
            if target.startswith(("/episode/", "/compare/")):
                assert answer.status == 200, (target, answer.raw[-500:])


def export(run: Path, out: Path) -> tuple[int, str]:
    """`cocobench view RUN --export OUT` in this process: its exit code and stderr."""
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main(["view", str(run), "--export", str(out)])
    return code, err.getvalue()


def files_under(folder: Path) -> set[Path]:
    return {p for p in folder.rglob("*") if p.is_file() or p.is_symlink()}


@pytest.mark.slow
@settings(max_examples=EXAMPLES_PER_RUN, deadline=None, database=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                 HealthCheck.large_base_example])
@given(data=st.data())
def test_the_viewer_survives_any_run_folder(base: Base, tracebacks: Tracebacks,
                                            data: st.DataObject) -> None:
    example = base.examples / f"ex{next(EXAMPLES)}"
    run = Path(shutil.copytree(base.run, example / "run"))
    for change in data.draw(mutated(base.run), label="mutations"):
        write(run, change.file, change.content)
    common = base.examples.parents[len(NESTING) - 1]
    before = files_under(common)
    tracebacks.records.clear()

    serve_every_route(run)
    code, err = export(run, example / "site")

    assert code in (0, 2), err
    assert "Traceback" not in err
    assert err.count("\n") <= 3 or code == 0, err  # a mistake is said in one line
    assert [r.getMessage() for r in tracebacks.records] == []
    written = files_under(common) - before
    assert all(p.is_relative_to(example / "site") for p in written), sorted(written)
    assert not Path("/tmp/ESCAPED-ABSOLUTE").exists()
    assert [mark for mark in base.marks if mark.exists()] == []
    assert "canary_mod" not in sys.modules
    shutil.rmtree(example)
