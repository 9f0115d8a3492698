"""No exception can hang a run (issue 34, item 2).

Whatever an episode raises, in any phase (the model's reply, parsing, the simulator,
scoring, writing the trajectory) and in any executor (this process, worker processes, Ray),
the episode is recorded as an infrastructure error naming the exception's type and message,
and the run goes on and ends. The faults are planted by `planted/sitecustomize.py`: patched
here for the executors this process runs, and through PYTHONPATH in every process of a
`cocobench run` (forked workers and Ray's workers included). A worker's episode that never
reports is ended by the supervisor at its timeout. A reply holding a lone surrogate, through
either transport, is the model's (made writable) reply, never a crash.
"""

from __future__ import annotations

import asyncio
import importlib
import importlib.util
import json
import multiprocessing
import os
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from benchmark_adapter.tasks import load_tasks
from cocobench_agents.harness import (
    Condition,
    ExecutionSettings,
    InProcess,
    WorkerProcesses,
    plan_episodes,
)
from cocobench_agents.harness.executor import Bounds
from cocobench_agents.models import ModelPool
from cocobench_agents.runfolder import RunFolder
from tests.models.fake_openai import FakeOpenAI, ok

PLANTED = Path(__file__).with_name("planted")
_spec = importlib.util.spec_from_file_location("planted_faults", PLANTED / "sitecustomize.py")
assert _spec is not None and _spec.loader is not None
planted = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(planted)

PHASES = list(planted.TARGETS)
#: What each phase's episode records: a model's failure is the decision's backend error
#: (the episode is one of the run's infrastructure failures); any other, the result line's.
NAMED = {"reply": "PlantedFault('planted in reply')",
         "parse": "PlantedFault: planted in parse",
         "step": "PlantedFault: planted in step",
         "score": "PlantedFault('planted in score')",
         "write": "the trajectory could not be written: UnicodeEncodeError: "}
DEADLINE_S = 90  # a run past this hangs: the test fails instead of waiting forever


@pytest.fixture
def deadline() -> Iterator[None]:
    """Fail (TimeoutError in this thread) instead of hanging: the executor stops its workers
    on the way out."""
    def expired(*_: Any) -> None:
        raise TimeoutError(f"the run hung for {DEADLINE_S} s")

    previous = signal.signal(signal.SIGALRM, expired)
    signal.alarm(DEADLINE_S)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


def plant(monkeypatch: pytest.MonkeyPatch, phase: str) -> None:
    module, attribute = planted.TARGETS[phase]
    owner, name = planted.target(importlib.import_module(module), attribute)
    monkeypatch.setattr(owner, name, planted.fault(phase))


def plan(count: int = 2):
    return plan_episodes(load_tasks("demo")[:count], ["greedy"],
                         [Condition("centralized", "blind")], 1)


def assert_named(record: dict[str, Any], folder: RunFolder, phase: str) -> None:
    """The episode is recorded as failing on the planted exception, by type and message."""
    if phase == "reply":  # the client's failure: a backend error of the decision
        assert record["backend_errors"] >= 1 and not record.get("infra_error")
        decisions = folder.trajectory(record)["planner_decisions"]  # type: ignore[index]
        assert any(NAMED[phase] in str(d.get("error")) for d in decisions)
    else:
        assert NAMED[phase] in record["infra_error"]


EXECUTORS = [pytest.param(InProcess(), ExecutionSettings(jobs=2), id="in-process"),
             pytest.param(WorkerProcesses(), ExecutionSettings(jobs=2, workers=1),
                          id="1-worker"),
             pytest.param(WorkerProcesses(), ExecutionSettings(jobs=2, workers=2),
                          id="2-workers")]


@pytest.mark.parametrize("phase", PHASES)
@pytest.mark.parametrize(("executor", "settings"), EXECUTORS)
def test_a_fault_in_any_phase_is_recorded_and_the_run_ends(tmp_path, monkeypatch, deadline,
                                                           executor, settings, phase):
    plant(monkeypatch, phase)  # the workers fork: they inherit it
    planned = plan()
    folder = RunFolder(tmp_path / "run")
    folder.create({"name": phase})
    executor.run(planned, folder, ModelPool(), settings)
    records = list(folder.results())
    assert sorted(r["task_id"] for r in records) == sorted(p.key.task_id for p in planned)
    for record in records:
        assert_named(record, folder, phase)
    assert multiprocessing.active_children() == []


def test_an_episode_the_worker_never_reports_is_ended_at_its_timeout(tmp_path, monkeypatch,
                                                                     deadline):
    """The supervisor's own watch: an episode that never ends in its worker (a task that
    died without a word, a timeout that did not fire) is recorded as timed out once past
    --episode-timeout, its worker stopped; the run ends."""
    from cocobench_agents.harness import workers

    async def never_reports(*args: Any, **kwargs: Any) -> Any:
        await asyncio.Event().wait()

    monkeypatch.setattr(workers, "run_one", never_reports)  # forked: inherited
    monkeypatch.setattr(workers, "OVERDUE_GRACE_S", 0.5)
    planned = plan(1)
    folder = RunFolder(tmp_path / "run")
    folder.create({"name": "silent"})
    WorkerProcesses().run(planned, folder, ModelPool(), ExecutionSettings(jobs=1, workers=1),
                          bounds=Bounds(episode_timeout_s=0.5))
    (record,) = folder.results()
    assert record["infra_error"] == ("episode timed out after 0.5 s of wall-clock time "
                                     "(--episode-timeout)")
    assert multiprocessing.active_children() == []


#: How many episodes this process (a forked worker: its own count) has been given.
_GIVEN = [0]


@pytest.mark.slow
def test_an_overdue_episode_stops_its_worker_and_the_others_there_run_again(
        tmp_path, monkeypatch, deadline):
    """An episode past its timeout stops its worker while another episode is in flight
    there: that one runs again alone, once, in a new worker (here it never reports either,
    and is recorded as timed out the second time, `requeued` 1); nothing is lost."""
    from cocobench_agents.harness import workers

    real_run_one = workers.run_one

    async def first_hangs_second_ends(*args: Any, **kwargs: Any) -> Any:
        _GIVEN[0] += 1
        if _GIVEN[0] == 2:  # ends after 0.7 s and its run: the third starts then, in flight
            await asyncio.sleep(0.7)  # when the first is overdue (2 s), itself not (2.7 s)
            return await real_run_one(*args, **kwargs)
        await asyncio.Event().wait()

    monkeypatch.setattr(workers, "run_one", first_hangs_second_ends)  # forked: inherited
    monkeypatch.setattr(workers, "OVERDUE_GRACE_S", 1.5)
    planned = plan(3)
    folder = RunFolder(tmp_path / "run")
    folder.create({"name": "overdue"})
    WorkerProcesses().run(planned, folder, ModelPool(), ExecutionSettings(jobs=2, workers=1),
                          bounds=Bounds(episode_timeout_s=0.5))
    records = list(folder.results())
    assert sorted(r["task_id"] for r in records) == sorted(p.key.task_id for p in planned)
    timeout = "episode timed out after 0.5 s of wall-clock time (--episode-timeout)"
    second, first, third = records  # in the order they ended
    assert "requeued" not in second
    assert first["infra_error"] == timeout and "requeued" not in first
    assert third["infra_error"] == timeout and third["requeued"] == 1
    assert multiprocessing.active_children() == []


def test_a_worker_reports_an_episode_whose_result_it_cannot_make(tmp_path, monkeypatch,
                                                                 deadline):
    """Whatever escapes the episode in a worker (here its runner itself) is sent to the
    supervisor, which records it; no task of the worker ends in silence."""
    from cocobench_agents.harness import workers

    async def broken(*args: Any, **kwargs: Any) -> Any:
        raise KeyError("nowhere")

    monkeypatch.setattr(workers, "run_one", broken)
    planned = plan()
    folder = RunFolder(tmp_path / "run")
    folder.create({"name": "broken"})
    WorkerProcesses().run(planned, folder, ModelPool(), ExecutionSettings(jobs=2, workers=2))
    records = list(folder.results())
    assert len(records) == len(planned)
    assert all(r["infra_error"] == "KeyError: 'nowhere'" for r in records)


@pytest.mark.parametrize(("executor", "settings"), EXECUTORS[:2])
def test_an_exception_whose_message_no_utf8_file_holds_is_recorded(tmp_path, monkeypatch,
                                                                   deadline, executor,
                                                                   settings):
    from benchmark_adapter.episode import Episode

    def step(*args: Any, **kwargs: Any) -> Any:
        raise RuntimeError("bad \ud800 text")

    monkeypatch.setattr(Episode, "step", step)
    folder = RunFolder(tmp_path / "run")
    folder.create({"name": "surrogate"})
    executor.run(plan(1), folder, ModelPool(), settings)
    (record,) = folder.results()
    assert "RuntimeError: bad \\ud800 text" in record["infra_error"]


# -- the whole command, in every executor -------------------------------------------------------

CLI_EXECUTORS = [pytest.param(["--workers", "1"], id="1-worker"),
                 pytest.param(["--workers", "2", "--jobs", "2"], id="2-workers"),
                 pytest.param(["--executor", "ray", "--workers", "2"], id="ray",
                              marks=pytest.mark.needs_ray)]


def cocobench(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "cocobench_agents.cli", *args],
                          capture_output=True, text=True, timeout=DEADLINE_S * 2,
                          env={**os.environ, "NO_COLOR": "1", **(env or {})})


@pytest.mark.slow
@pytest.mark.parametrize("phase", PHASES)
@pytest.mark.parametrize("executor", CLI_EXECUTORS)
def test_a_planted_fault_ends_the_run_with_every_episode_recorded(tmp_path, executor, phase):
    out = tmp_path / "run"
    path = os.pathsep.join([str(PLANTED), os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    result = cocobench("run", "--suite", "demo", "--limit", "2", "--planner", "centralized",
                       "--obs", "blind", "--model", "greedy", *executor, "--out", str(out),
                       env={planted.VARIABLE: phase, "PYTHONPATH": path})
    assert result.returncode == 1, result.stderr
    assert f"cocobench run --out {out} --resume --retry-errors" in result.stderr
    assert "Traceback" not in result.stderr
    folder = RunFolder(out)
    records = list(folder.results())
    assert len(records) == 2
    for record in records:
        assert_named(record, folder, phase)


@pytest.mark.slow
@pytest.mark.parametrize("executor", [CLI_EXECUTORS[0], CLI_EXECUTORS[2]])
def test_an_episode_that_never_reports_is_ended_by_the_supervisor(tmp_path, executor):
    """The worker's episode neither ends nor reports (its own timeout bypassed): the
    supervisor (a Ray run's driver) records it as timed out half a second past
    --episode-timeout, stops that worker, and the run ends."""
    out = tmp_path / "run"
    path = os.pathsep.join([str(PLANTED), os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    result = cocobench("run", "--suite", "demo", "--limit", "2", "--planner", "centralized",
                       "--obs", "blind", "--model", "greedy", "--episode-timeout", "1",
                       *executor, "--out", str(out),
                       env={planted.VARIABLE: planted.SILENT, "PYTHONPATH": path})
    assert result.returncode == 1, result.stderr
    assert f"cocobench run --out {out} --resume --retry-errors" in result.stderr
    records = list(RunFolder(out).results())
    assert len(records) == 2
    assert all(r["infra_error"] == "episode timed out after 1 s of wall-clock time "
               "(--episode-timeout)" for r in records)


# -- a reply holding a lone surrogate -------------------------------------------------------------

SURROGATE_REPLY = "REASON: \ud800 x\nACTION: 0"  # sent as the JSON escape "\ud800"


@pytest.mark.slow
@pytest.mark.parametrize("transport", ["litellm", "http"])
def test_a_reply_with_a_lone_surrogate_is_the_models_reply_never_a_hang(tmp_path, transport):
    out = tmp_path / "run"
    with FakeOpenAI(ok(SURROGATE_REPLY)) as server:
        result = cocobench("run", "--suite", "demo", "--limit", "1", "--planner",
                           "centralized", "--obs", "blind", "--model", "openai/fake-model",
                           "--api-base", server.base_url, "--transport", transport,
                           "--no-preflight", "--max-steps", "2", "--max-retries", "1",
                           "--out", str(out), env={"OPENAI_API_KEY": "sk-fake"})
        assert b"\\ud800" in json.dumps(server.default.body).encode()
    assert result.returncode == 0, result.stderr
    folder = RunFolder(out)
    (record,) = folder.results()
    assert not record.get("infra_error") and record["backend_errors"] == 0
    decisions = folder.trajectory(record)["planner_decisions"]  # type: ignore[index]
    replies = [d["raw_output"] for d in decisions if "raw_output" in d]
    assert replies and all(r == "REASON: \ufffd x\nACTION: 0" for r in replies)


# -- a task config holding a lone surrogate ----------------------------------------------------


def test_a_task_config_with_a_lone_surrogate_is_refused_naming_file_and_field(tmp_path,
                                                                             deadline, capsys):
    from cocobench_agents.cli import main

    source = Path(load_tasks("demo")[0].source)
    text = source.read_text(encoding="utf-8")
    task = tmp_path / "task.json"
    task.write_text(text.replace('"Agent-1"', '"Agent-\\ud800"', 1), encoding="utf-8")
    assert "\\ud800" in task.read_text(encoding="utf-8")
    for command in (["validate", str(task)],
                    ["run", "--task", str(task), "--model", "greedy", "--obs", "blind",
                     "--out", str(tmp_path / "run")]):
        capsys.readouterr()
        assert main(command) == 2
        err = capsys.readouterr().err
        assert f"{task}: agents.0.role: not valid UTF-8 text: a lone surrogate (\\ud800" in err
        assert "Traceback" not in err
    assert not (tmp_path / "run" / "results.jsonl").exists()

    # Text written as a surrogate pair's escapes is one valid character, and loads.
    task.write_text(text.replace('"Agent-1"', '"Agent-\\ud83d\\ude00"', 1), encoding="utf-8")
    assert main(["validate", str(task)]) == 0


def test_an_out_path_that_is_not_utf8_is_refused_in_one_line(tmp_path, capsys):
    from cocobench_agents.cli import main

    out = tmp_path / "run\udcff"  # as Python reads a path's byte 0xff from the command line
    assert main(["run", "--suite", "demo", "--limit", "1", "--model", "greedy", "--obs",
                 "blind", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert (f"cannot write {tmp_path}/run\\xff/run.json: the run's request holds text "
            "that is not valid UTF-8") in err
    assert "Traceback" not in err
