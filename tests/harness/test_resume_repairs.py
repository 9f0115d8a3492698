"""What a resume repairs or refuses in the folder it completes (issue 34): a trajectory cut
short or empty counts as not done and runs again; temporary files of writes a killed worker
left are removed (in the run folder only); a `run.json` of a record version this code does not
know is refused naming the version, not as a plan that differs."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from cocobench_agents.cli import main

RUN = ["run", "--suite", "demo", "--limit", "2", "--model", "greedy", "--planner",
       "centralized", "--obs", "blind"]


@pytest.fixture
def run_folder(tmp_path: Path) -> Path:
    out = tmp_path / "run"
    assert main([*RUN, "--out", str(out)]) == 0
    return out


def lines(out: Path) -> list[dict]:
    return [json.loads(line) for line in (out / "results.jsonl").read_text().splitlines()]


def trajectories(out: Path) -> list[Path]:
    return sorted(out / line["trajectory"] for line in lines(out))


def test_a_trajectory_cut_short_or_empty_runs_again(run_folder, capsys):
    first, second = trajectories(run_folder)
    whole = first.read_bytes()
    # Cut after an inner object's brace: the file still ends with "}", but is not whole.
    first.write_bytes(whole[:whole.rindex(b"\n  }") + 4])
    assert first.read_bytes().endswith(b"}")
    second.write_bytes(b"")
    capsys.readouterr()
    assert main(["run", "--out", str(run_folder), "--resume"]) == 0
    err = capsys.readouterr().err
    assert f"{first}: cut short (" in err and f"{second}: empty;" in err
    assert len(lines(run_folder)) == 4  # both ran again
    assert first.read_bytes() == whole
    assert json.loads(second.read_bytes())["task_id"]
    # Whole again: a further resume has nothing to run.
    assert main(["run", "--out", str(run_folder), "--resume"]) == 0
    assert len(lines(run_folder)) == 4


def test_temporary_files_of_a_killed_writer_are_removed_inside_the_run_folder_only(
        run_folder, tmp_path, capsys):
    episode = trajectories(run_folder)[0].parent
    left = [episode / ".trajectory.json.k2j4x_1q.tmp", episode / ".prompts.json.gz.9ab.tmp"]
    for path in left:
        path.write_bytes(b'{"task_id": ')
    kept = episode / "notes.tmp"  # not a name the folder's writes make
    kept.write_text("mine")
    outside = tmp_path / "elsewhere"
    outside.mkdir()
    theirs = outside / ".trajectory.json.abc.tmp"
    theirs.write_text("not the run's")
    (run_folder / "link").symlink_to(outside, target_is_directory=True)
    capsys.readouterr()
    assert main(["run", "--out", str(run_folder), "--resume"]) == 0
    assert "removed 2 temporary files" in capsys.readouterr().err
    assert not any(path.exists() for path in left)
    assert kept.read_text() == "mine" and theirs.read_text() == "not the run's"


def test_an_unknown_record_version_is_named_on_resume(run_folder, capsys):
    record_path = run_folder / "run.json"
    record = json.loads(record_path.read_text())
    record["record_version"] = 99
    record_path.write_text(json.dumps(record))
    capsys.readouterr()
    assert main(["run", "--out", str(run_folder), "--resume"]) == 2
    err = capsys.readouterr().err
    assert (f"{record_path}: record_version 99 is not one this version of cocobench-agents "
            "reads (1, 2)") in err
    assert "differ" not in err and "Traceback" not in err
