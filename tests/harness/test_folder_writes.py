"""Result lines are appended whole or not at all; a run folder that cannot be written (a full
disk) stops the run with a one-line message and a non-zero exit, what was recorded stays
valid, and `--resume` completes it."""

from __future__ import annotations

import errno
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from cocobench_agents.cli import main
from cocobench_agents.runfolder import folder as run_folder
from cocobench_agents.runfolder import json_lines
from cocobench_agents.runfolder.errors import RunFolderWriteError
from cocobench_agents.runfolder.folder import RunFolder

REAL_WRITE = os.write
RUN = ["run", "--suite", "demo", "--model", "greedy", "--conditions", "all"]


def record(n: int) -> dict:
    return {"model": "greedy", "condition": "C0_image", "task_id": f"t{n}", "epoch": 0,
            "task_success": 1, "note": "x" * 300}


def test_short_writes_are_completed(tmp_path, monkeypatch):
    monkeypatch.setattr(json_lines.os, "write", lambda fd, data: REAL_WRITE(fd, bytes(data[:7])))
    folder = RunFolder(tmp_path)
    for n in range(3):
        folder.append_result(record(n))
    monkeypatch.undo()
    assert [r["task_id"] for r in folder.results()] == ["t0", "t1", "t2"]
    assert folder.scan_results().problems == []


@pytest.mark.parametrize("code", [errno.ENOSPC, errno.EIO, errno.EDQUOT])
def test_a_failed_append_is_cut_back_and_stops_the_run(tmp_path, monkeypatch, code):
    folder = RunFolder(tmp_path)
    folder.append_result(record(0))
    before = folder.results_path.read_bytes()
    calls = []

    def half_then_full(fd, data):  # the disk fills up in the middle of the line
        calls.append(len(data))
        if len(calls) == 1:
            return REAL_WRITE(fd, bytes(data[: len(data) // 2]))
        raise OSError(code, os.strerror(code))

    monkeypatch.setattr(json_lines.os, "write", half_then_full)
    with pytest.raises(RunFolderWriteError, match=os.strerror(code)):
        folder.append_result(record(1))
    monkeypatch.undo()
    assert folder.results_path.read_bytes() == before  # no partial line left
    folder.append_result(record(2))  # space again: the next line is whole
    assert [r["task_id"] for r in folder.results()] == ["t0", "t2"]


@pytest.mark.parametrize("workers", ["1", "2"])
def test_a_trajectory_that_cannot_be_written_stops_the_run(tmp_path, monkeypatch, capfd,
                                                           workers):
    attempts = []
    real = run_folder.write_json_atomic

    def disk_full(path, document):
        if not str(path).endswith("trajectory.json"):
            return real(path, document)  # run.json
        attempts.append(path)
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(run_folder, "write_json_atomic", disk_full)
    out = tmp_path / "run"
    code = main([*RUN, "--out", str(out), "--jobs", "2", "--workers", workers])
    err = capfd.readouterr().err
    assert code == 1
    assert "the run stopped: cannot write" in err and "No space left on device" in err
    assert f"cocobench run --out {out} --resume" in err
    assert "Traceback" not in err
    # The run stopped at once: no episode was recorded as an infrastructure error.
    results = out / "results.jsonl"
    assert not results.exists() or results.read_text() == ""
    if workers == "1":  # (a forked worker's attempts are not counted here)
        assert len(attempts) <= 2  # the episodes in flight (--jobs 2), not all 24


def test_a_torn_tail_that_cannot_be_cut_stops_the_resume_and_loses_nothing(
        tmp_path, monkeypatch, capfd):
    """Resuming cuts a killed run's torn last line off; a results file that cannot be
    written (no permission to a copied folder's file, a read-only disk) stops the resume
    with the run folder's one-line message, the file as it was."""
    out = tmp_path / "run"
    assert main(["run", "--suite", "demo", "--model", "greedy", "--limit", "1",
                 "--out", str(out)]) == 0
    results = out / "results.jsonl"
    with results.open("ab") as f:
        f.write(b'{"torn')
    before = results.read_bytes()
    real_open = open

    def read_only(path, mode="r", *args, **kwargs):
        if mode == "r+b":
            raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), str(path))
        return real_open(path, mode, *args, **kwargs)

    monkeypatch.setattr(json_lines, "open", read_only, raising=False)
    capfd.readouterr()
    code = main(["run", "--out", str(out), "--resume"])
    err = capfd.readouterr().err
    assert code == 1 and "Traceback" not in err
    assert f"the run stopped: cannot write {results}: Permission denied" in err
    assert f"cocobench run --out {out} --resume" in err
    assert results.read_bytes() == before


def _mount_tmpfs(path: Path, size: str) -> None:
    path.mkdir()
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(path)],
                          capture_output=True, text=True)
    if done.returncode != 0:
        pytest.skip(f"cannot mount a small tmpfs here ({done.stderr.strip()})")


@pytest.mark.slow
def test_a_real_full_disk_stops_the_run_and_resume_completes_it(tmp_path):
    disk = tmp_path / "disk"
    _mount_tmpfs(disk, "1m")  # room for a few trajectories of the 24
    try:
        out = disk / "run"
        command = [sys.executable, "-m", "cocobench_agents.cli", *RUN, "--out", str(out),
                   "--jobs", "1"]
        full = subprocess.run(command, capture_output=True, text=True, timeout=300)
        assert full.returncode == 1, full.stderr
        assert "No space left on device" in full.stderr and "--resume" in full.stderr
        assert "Traceback" not in full.stderr
        lines = (out / "results.jsonl").read_text().splitlines()
        assert 0 < len(lines) < 24
        for line in lines:  # what was recorded stays valid: whole lines, trajectories there
            assert (out / json.loads(line)["trajectory"]).is_file()
        subprocess.run(["mount", "-o", "remount,size=64m", str(disk)], check=True)
        resumed = subprocess.run([*command, "--resume"], capture_output=True, text=True,
                                 timeout=300)
        assert resumed.returncode == 0, resumed.stderr
        assert f"({len(lines)} already done)" in resumed.stderr
        assert "warning" not in resumed.stderr
        assert len((out / "results.jsonl").read_text().splitlines()) == 24
    finally:
        subprocess.run(["umount", str(disk)], check=False)
