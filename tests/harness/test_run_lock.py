"""One process per run folder: a second `cocobench run` on a folder in use exits 2 naming the
holder's pid; the lock of a SIGKILLed holder is taken over; nothing is run twice."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from cocobench_agents.runfolder.folder import RunFolder
from cocobench_agents.runfolder.lock import LOCK_FILE, RunLock, RunLocked

RUN = [sys.executable, "-m", "cocobench_agents.cli", "run", "--model", "random:7",
       "--conditions", "all", "--jobs", "1"]


def start_run(out: Path, *options: str, results: int = 1) -> subprocess.Popen:
    """A real run in the background, returned once it has recorded `results` lines."""
    process = subprocess.Popen([*RUN, "--out", str(out), *options],
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 120
    path = out / "results.jsonl"
    while time.monotonic() < deadline:
        if path.exists() and len(path.read_bytes().splitlines()) >= results:
            return process
        assert process.poll() is None, "the run ended before recording anything"
        time.sleep(0.02)
    process.kill()
    raise AssertionError("the run recorded nothing in 120 s")


def run(out: Path, *options: str) -> subprocess.CompletedProcess:
    return subprocess.run([*RUN, "--out", str(out), *options], capture_output=True,
                          text=True, timeout=300)


def keys(out: Path) -> list[tuple]:
    lines = [json.loads(line) for line in (out / "results.jsonl").read_text().splitlines()]
    return [(r["model"], r["condition"], r["task_id"], r["epoch"]) for r in lines]


@pytest.mark.slow
def test_a_second_process_exits_2_naming_the_holder(tmp_path):
    out = tmp_path / "run"
    holder = start_run(out, "--suite", "cocobench-240")  # 1,440 episodes: still running
    try:
        second = run(out, "--resume")
        assert second.returncode == 2
        assert f"in use by another cocobench run (pid {holder.pid})" in second.stderr
        assert "Traceback" not in second.stderr and len(second.stderr.splitlines()) == 1
        assert holder.poll() is None  # the holder was not disturbed
    finally:
        holder.kill()
        holder.wait()
    recorded = keys(out)
    assert len(recorded) == len(set(recorded))  # nothing ran twice


@pytest.mark.slow
def test_a_killed_holders_lock_is_taken_over_and_the_run_completed(tmp_path):
    out = tmp_path / "run"
    holder = start_run(out, "--suite", "demo", results=3)
    os.kill(holder.pid, signal.SIGKILL)
    holder.wait()
    assert (out / LOCK_FILE).read_text().strip() == str(holder.pid)  # left by the kill
    resumed = run(out, "--resume")
    assert resumed.returncode == 0, resumed.stderr
    assert f"taking over the lock of pid {holder.pid}" in resumed.stderr
    recorded = keys(out)
    assert len(recorded) == 24 == len(set(recorded))
    assert (out / LOCK_FILE).read_text() == ""  # released cleanly


def test_the_lock_is_per_open_file_and_released_cleanly(tmp_path):
    folder = tmp_path / "run"
    with RunLock(folder) as first:
        assert first.stale_pid is None
        assert (folder / LOCK_FILE).read_text() == f"{os.getpid()}\n"
        with pytest.raises(RunLocked, match=f"pid {os.getpid()}"):
            RunLock(folder).acquire()
        (folder / "results.jsonl").write_text("")
    assert (folder / LOCK_FILE).read_text() == ""
    with RunLock(folder) as again:
        assert again.stale_pid is None  # an empty file: the last holder released it


def test_a_folder_made_only_for_the_lock_is_removed(tmp_path):
    folder = tmp_path / "new"
    with RunFolder(folder).lock():
        assert folder.is_dir()
    assert not folder.exists()  # a run refused before it recorded anything leaves no folder
    existing = tmp_path / "existing"
    existing.mkdir()
    with RunFolder(existing).lock():
        pass
    assert existing.is_dir()  # never removes a folder it did not make


def test_a_user_mistake_leaves_no_folder_and_no_lock(tmp_path):
    out = tmp_path / "run"
    refused = subprocess.run([*RUN, "--suite", "demo", "--out", str(out), "--epochs", "1",
                              "--conditions", "Z9_image"], capture_output=True, text=True,
                             timeout=120)
    assert refused.returncode == 2 and "Traceback" not in refused.stderr
    assert not out.exists()
