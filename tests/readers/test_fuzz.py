"""Readers survive any run folder (issue 34): a property-based test changes one field or file
of a real run folder (`mutations`) and runs `cocobench report`, `export`, `score` and
`run --resume` on it. Each answers in one line or works (exit 0 or 2; 1 for a resumed run
only, whose meaning is "the run had infrastructure errors"), never with a traceback; no file
is written outside its output folder; and the canary planted in the run folder (a `.py` file
that code references name) and the canary module on `sys.path` never run: run data is data."""

from __future__ import annotations

import itertools
import os
import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cocobench_agents.cli import main
from tests.readers.conftest import CANARY_MODULE, planted_copy
from tests.readers.mutations import Mutation, apply, fresh, mutations, tree

#: Settings of every property here: examples bounded, no deadline (a report takes a second
#: now and then), no example database written into the working directory.
BOUNDED = dict(deadline=None, database=None, derandomize=False,
               suppress_health_check=[HealthCheck.function_scoped_fixture,
                                      HealthCheck.too_slow, HealthCheck.data_too_large])


def examples(default: int) -> int:
    """How many examples a property tries: `default`, or COCOBENCH_FUZZ_EXAMPLES (a longer
    search by hand)."""
    return int(os.environ.get("COCOBENCH_FUZZ_EXAMPLES") or default)


class Sandbox:
    """One example's folders: the changed run five levels below a root whose whole tree is
    compared before and after (a `../` escape of up to five levels lands in it), and the
    commands' output folder beside the run."""

    counter = itertools.count()

    def __init__(self, base: Path) -> None:
        self.root = base / f"example{next(self.counter)}"
        fresh(self.root)
        self.home = self.root / "l1" / "l2" / "l3" / "l4"
        self.run = self.home / "run"
        self.out = self.home / "out"

    def changed_files(self, before: dict[str, tuple[int, int]], *allowed: Path) -> list[str]:
        """Files created or changed since `before` outside the `allowed` folders."""
        inside = [str(path.relative_to(self.root)) + os.sep for path in allowed]
        after = tree(self.root)
        return sorted(name for name, stat in after.items()
                      if before.get(name) != stat and not name.startswith(tuple(inside)))


def command(capsys: pytest.CaptureFixture[str], *args: str | Path) -> tuple[int, str]:
    """`cocobench ARGS` in this process: its exit code and what it printed."""
    capsys.readouterr()
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out + err


@pytest.fixture
def canary_module(canary: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """The canary module importable (its folder on `sys.path`); the marker it would write."""
    monkeypatch.syspath_prepend(str(canary.parent))
    return canary


@pytest.fixture
def base(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("fuzz")


def check_reader(capsys, sandbox: Sandbox, canary: Path, mutation: Mutation,
                 args: list[str | Path], codes: set[int], writes: Path) -> None:
    before = tree(sandbox.root)
    code, printed = command(capsys, *args)
    assert code in codes, f"{mutation}\n{args[0]} exit {code}:\n{printed}"
    assert "Traceback" not in printed, f"{mutation}\n{printed}"
    assert sandbox.changed_files(before, writes) == [], f"{mutation}: {args[0]} wrote outside"
    assert not canary.exists(), f"{mutation}: {args[0]} ran the canary"
    assert CANARY_MODULE not in sys.modules, f"{mutation}: {args[0]} imported the canary"


def readers(capsys, demo_run: Path, canary: Path, base: Path, data: st.DataObject,
            export: bool) -> None:
    sandbox = Sandbox(base)
    run = planted_copy(demo_run, canary, sandbox.run)
    mutation = data.draw(mutations(run), label="mutation")
    apply(mutation, run, sandbox.root)
    os.chdir(run)  # relative code references name the planted canary
    check_reader(capsys, sandbox, canary, mutation,
                 ["report", run, "--out", sandbox.out / "report", "--no-plots",
                  "--resamples", "20"], {0, 2}, sandbox.out)
    check_reader(capsys, sandbox, canary, mutation,
                 ["score", *sorted(run.glob("episodes/**/trajectory.json"))], {0, 2},
                 sandbox.out)
    if export:
        check_reader(capsys, sandbox, canary, mutation,
                     ["export", run, "--out", sandbox.out / "dataset"], {0, 2}, sandbox.out)


@pytest.mark.slow
@settings(max_examples=examples(60), **BOUNDED)
@given(data=st.data())
def test_report_and_score_survive_any_run_folder(capsys, demo_run, canary_module, base,
                                                 monkeypatch, data):
    monkeypatch.chdir(base)
    readers(capsys, demo_run, canary_module, base, data, export=False)


@pytest.mark.slow
@pytest.mark.needs_export
@settings(max_examples=examples(40), **BOUNDED)
@given(data=st.data())
def test_export_survives_any_run_folder(capsys, demo_run, canary_module, base, monkeypatch,
                                        data):
    monkeypatch.chdir(base)
    readers(capsys, demo_run, canary_module, base, data, export=True)


@pytest.mark.slow
@settings(max_examples=examples(8), **BOUNDED)
@given(data=st.data())
def test_resume_survives_any_run_folder(capsys, demo_run, canary_module, base, monkeypatch,
                                        data):
    """A resumed run reads `run.json` and the results; it writes only in its run folder.
    Exit 1 is its documented answer to episodes that ended in infrastructure errors."""
    monkeypatch.chdir(base)
    sandbox = Sandbox(base)
    run = planted_copy(demo_run, canary_module, sandbox.run)
    mutation = data.draw(mutations(run), label="mutation")
    apply(mutation, run, sandbox.root)
    os.chdir(run)
    check_reader(capsys, sandbox, canary_module, mutation,
                 ["run", "--out", run, "--resume"], {0, 1, 2}, run)
