"""`removed_on_failure`: a failing command takes back what it wrote, and only that."""

from __future__ import annotations

import errno

import pytest

from cocobench_agents.partial_output import removed_on_failure


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
