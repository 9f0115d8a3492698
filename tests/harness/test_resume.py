"""A run killed by a real SIGKILL midway and resumed equals an uninterrupted run, episode for
episode; results do not depend on --jobs; an existing folder is refused without --resume."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

RUN = [sys.executable, "-m", "cocobench_agents.cli", "run", "--suite", "demo",
       "--model", "random:7", "--conditions", "all"]


def cocobench(out: Path, *extra: str) -> subprocess.CompletedProcess:
    return subprocess.run([*RUN, "--out", str(out), *extra], capture_output=True, text=True,
                          timeout=300)


def episodes(folder: Path) -> dict[tuple, dict]:
    """Result lines by episode key, without wall-clock fields; plus trajectory texts."""
    out = {}
    for line in (folder / "results.jsonl").read_text().splitlines():
        record = json.loads(line)
        key = (record["model"], record["condition"], record["task_id"], record["epoch"])
        record.pop("elapsed_s")
        trajectory = (folder / record["trajectory"]).read_text()
        out[key] = (record, trajectory)
    return out


def start_and_wait_for_results(out: Path, *extra: str, count: int = 5) -> subprocess.Popen:
    """Start a run in the background; return once `count` results are recorded."""
    process = subprocess.Popen([*RUN, "--out", str(out), *extra],
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    results = out / "results.jsonl"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        if results.exists() and len(results.read_text().splitlines()) >= count:
            break
        time.sleep(0.01)
    return process


@pytest.fixture(scope="module")
def reference_run(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("runs") / "whole"
    done = cocobench(out, "--jobs", "1")
    assert done.returncode == 0, done.stderr
    return out


@pytest.mark.slow
def test_a_killed_and_resumed_run_equals_an_uninterrupted_one(reference_run, tmp_path):
    out = tmp_path / "killed"
    process = start_and_wait_for_results(out, "--jobs", "2")
    results = out / "results.jsonl"
    os.kill(process.pid, signal.SIGKILL)
    process.wait()
    recorded = len(results.read_text().splitlines())
    assert 5 <= recorded < 24, "the kill must land midway"

    refused = cocobench(out)
    assert refused.returncode == 2 and "--resume" in refused.stderr

    resumed = cocobench(out, "--resume")
    assert resumed.returncode == 0, resumed.stderr
    assert f"({recorded} already done)" in resumed.stderr or "already done" in resumed.stderr
    assert episodes(out) == episodes(reference_run)


def test_results_do_not_depend_on_jobs(reference_run, tmp_path):
    out = tmp_path / "parallel"
    done = cocobench(out, "--jobs", "8")
    assert done.returncode == 0, done.stderr
    assert episodes(out) == episodes(reference_run)


def test_results_do_not_depend_on_worker_processes(reference_run, tmp_path):
    out = tmp_path / "workers"
    done = cocobench(out, "--jobs", "4", "--workers", "2")
    assert done.returncode == 0, done.stderr
    assert episodes(out) == episodes(reference_run)


@pytest.mark.skipif(not Path(f"/proc/{os.getpid()}/task/{os.getpid()}/children").exists(),
                    reason="needs Linux /proc child lists")
@pytest.mark.slow
def test_killing_the_parent_kills_its_workers_and_resume_completes(reference_run, tmp_path):
    out = tmp_path / "killed-workers"
    process = start_and_wait_for_results(out, "--jobs", "2", "--workers", "2")
    results = out / "results.jsonl"
    children_file = Path(f"/proc/{process.pid}/task/{process.pid}/children")
    workers = [int(pid) for pid in children_file.read_text().split()]
    assert len(workers) == 2
    os.kill(process.pid, signal.SIGKILL)
    process.wait()
    deadline = time.monotonic() + 10
    while any(Path(f"/proc/{pid}").exists() for pid in workers) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not any(Path(f"/proc/{pid}").exists() for pid in workers), "orphaned workers"
    assert len(results.read_text().splitlines()) < 24, "the kill must land midway"

    resumed = cocobench(out, "--resume", "--workers", "2")
    assert resumed.returncode == 0, resumed.stderr
    assert episodes(out) == episodes(reference_run)
