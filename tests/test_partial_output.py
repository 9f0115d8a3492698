"""`removed_on_failure`: a failing command takes back what it wrote, and only that.
`staged_beside`: what a killed writer staged beside its output is removed by the next writer,
and only once its writer is gone."""

from __future__ import annotations

import errno
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from cocobench_agents.partial_output import reclaim_abandoned, removed_on_failure, staged_beside


def _fill(out, disk_full: bool) -> None:
    (out / "episodes" / "a").mkdir(parents=True)
    (out / "run.json").write_text("{}")
    if disk_full:
        raise OSError(errno.ENOSPC, "No space left on device")


def test_a_new_folder_is_removed_whole(tmp_path):
    out = tmp_path / "new"
    with pytest.raises(OSError, match="No space"), removed_on_failure(out):
        out.mkdir()
        _fill(out, disk_full=True)
    assert not out.exists()


def test_what_the_folder_held_before_is_left_as_it_was(tmp_path):
    out = tmp_path / "mine"
    (out / "notes").mkdir(parents=True)
    (out / "notes" / "keep.txt").write_text("mine")
    (out / "README").write_text("mine too")
    with pytest.raises(KeyboardInterrupt), removed_on_failure(out):
        _fill(out, disk_full=False)
        raise KeyboardInterrupt
    assert sorted(p.name for p in out.iterdir()) == ["README", "notes"]
    assert (out / "notes" / "keep.txt").read_text() == "mine"


def test_a_block_that_succeeds_keeps_everything(tmp_path):
    out = tmp_path / "done"
    with removed_on_failure(out):
        out.mkdir()
        _fill(out, disk_full=False)
    assert (out / "run.json").exists() and (out / "episodes" / "a").is_dir()


# A writer that stages beside OUT, says where, then waits for its stdin to close or is killed.
STAGER = """
import sys
from pathlib import Path
from cocobench_agents.partial_output import staged_beside

with staged_beside(Path(sys.argv[1]), folder=sys.argv[2] == "folder") as staged:
    (staged / "page.html" if staged.is_dir() else staged).write_text("half")
    print(staged, flush=True)
    sys.stdin.read()
"""


def _stager(out: Path, kind: str) -> tuple[subprocess.Popen, Path]:
    process = subprocess.Popen([sys.executable, "-c", STAGER, str(out), kind],
                               stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    return process, Path(process.stdout.readline().strip())


@pytest.mark.parametrize("kind", ["file", "folder"])
def test_a_killed_writers_staged_output_goes_with_the_next_writer_only(tmp_path, kind):
    out = tmp_path / "site"
    process, staged = _stager(out, kind)
    assert staged.parent == tmp_path and staged.name.startswith(".site.")
    assert reclaim_abandoned(out) == [] and staged.exists()  # its writer is alive
    process.send_signal(signal.SIGKILL)
    process.wait(timeout=30)
    assert staged.exists()  # a SIGKILL runs no clean-up
    other = tmp_path / "other"
    with staged_beside(other, folder=False):
        pass
    assert staged.exists()  # another output's writer leaves it
    with staged_beside(out, folder=kind == "folder") as mine:
        assert not staged.exists() and mine.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_a_writer_that_ends_leaves_nothing_staged(tmp_path):
    out = tmp_path / "bundle.tar.gz"
    process, staged = _stager(out, "file")
    assert staged.exists()
    process.communicate("", timeout=30)
    assert process.returncode == 0 and list(tmp_path.iterdir()) == []


def test_what_is_renamed_to_the_output_stays(tmp_path):
    out = tmp_path / "bundle.tar.gz"
    with staged_beside(out, folder=False) as staged:
        staged.write_text("whole")
        staged.replace(out)
    assert [p.name for p in tmp_path.iterdir()] == ["bundle.tar.gz"]
    assert out.read_text() == "whole"


def test_an_old_unlocked_fresh_entry_is_reclaimed_and_a_new_one_kept(tmp_path):
    # Killed between making its entry and locking it (microseconds): only age tells.
    out = tmp_path / "site"
    old, new = tmp_path / ".site.aaaa.new", tmp_path / ".site.bbbb.new"
    old.mkdir()
    new.touch()
    os.utime(old, (0, 0))
    assert reclaim_abandoned(out) == [old]
    assert [p.name for p in tmp_path.iterdir()] == [new.name]
