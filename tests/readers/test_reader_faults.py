"""The readers of a run folder (`report`, `export`, `score`, `run --resume`) on the folders of
issue 34: each answers in one line naming the file (exit 2; 1 for a report folder that
cannot be written), never with a traceback, and never runs code the folder names."""

from __future__ import annotations

import json
import os
import resource
import shutil
import signal
import subprocess
import sys
import uuid
from pathlib import Path

import pytest

from cocobench_agents.cli import main
from tests.paths import SHARED_TASKS
from tests.readers.conftest import CANARY_FILE, planted_copy

ROOT = Path(__file__).resolve().parents[2]


def cocobench(capsys: pytest.CaptureFixture[str], *args: str | Path) -> tuple[int, str, str]:
    capsys.readouterr()
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def one_error(capsys, *args: str | Path, code: int = 2) -> str:
    """The one error line of a command that must fail with exit `code` (click's usage lines
    above a report's may precede it)."""
    got, _, err = cocobench(capsys, *args)
    lines = [line for line in err.splitlines()
             if line.startswith(("Error: ", "cocobench: error: "))]
    assert got == code and len(lines) == 1, err
    assert "Traceback" not in err
    return lines[0]


@pytest.fixture
def run(demo_run: Path, canary: Path, tmp_path: Path) -> Path:
    return planted_copy(demo_run, canary, tmp_path / "run")


def edit_record(run: Path, change) -> None:
    record = json.loads((run / "run.json").read_text())
    change(record)
    (run / "run.json").write_text(json.dumps(record))


def first_line(run: Path) -> dict:
    return json.loads((run / "results.jsonl").read_text().splitlines()[0])


def append_line(run: Path, line: dict) -> None:
    with open(run / "results.jsonl", "a", encoding="utf-8") as f:
        f.write(json.dumps(line) + "\n")


@pytest.mark.parametrize("name", ["results.jsonl", "run.json"])
def test_a_folder_in_place_of_a_run_file_is_named(capsys, run, tmp_path, name):
    (run / name).unlink()
    (run / name).mkdir()
    assert f"{run / name}: unreadable (Is a directory)" in one_error(
        capsys, "report", run, "--out", tmp_path / "report", "--no-plots")


@pytest.mark.needs_export
@pytest.mark.parametrize("name", ["results.jsonl", "run.json"])
def test_export_names_a_folder_in_place_of_a_run_file(capsys, run, tmp_path, name):
    (run / name).unlink()
    (run / name).mkdir()
    assert f"{run / name}: unreadable (Is a directory)" in one_error(
        capsys, "export", run, "--out", tmp_path / "dataset")


@pytest.mark.parametrize(("field", "value", "named"), [
    ("models", 5, "plan.models"), ("conditions", {"C0_image": 1}, "plan.conditions"),
    ("task_ids", "A_D1__FloorPlan1__seed0", "plan.task_ids"), ("epochs", "two", "plan.epochs"),
])
def test_plan_fields_of_another_type_are_named(capsys, run, tmp_path, field, value, named):
    edit_record(run, lambda record: record["plan"].__setitem__(field, value))
    line = one_error(capsys, "report", run, "--out", tmp_path / "report", "--no-plots")
    assert f"{run / 'run.json'}: not a run record ({named}:" in line
    line = one_error(capsys, "run", "--out", run, "--resume")
    assert f"{run / 'run.json'}: not a run record ({named}:" in line


@pytest.mark.needs_export
def test_export_names_a_plan_field_of_another_type(capsys, run, tmp_path):
    edit_record(run, lambda record: record["plan"].__setitem__("models", 5))
    assert f"{run / 'run.json'}: not a run record (plan.models:" in one_error(
        capsys, "export", run, "--out", tmp_path / "dataset")


def test_an_epoch_of_ten_to_the_thirty_is_an_invalid_line(capsys, run, tmp_path):
    append_line(run, {**first_line(run), "epoch": 10**30})
    code, _, err = cocobench(capsys, "report", run, "--out", tmp_path / "report", "--no-plots")
    assert code == 0, err
    assert "1 invalid result line skipped" in err and "Traceback" not in err


@pytest.mark.needs_export
def test_export_skips_an_epoch_of_ten_to_the_thirty(capsys, run, tmp_path):
    append_line(run, {**first_line(run), "epoch": 10**30})
    code, _, err = cocobench(capsys, "export", run, "--out", tmp_path / "dataset")
    assert code == 0, err
    assert "line 5: invalid result: epoch: Input should be less than or equal to" in err


def test_a_lone_surrogate_in_a_result_line_is_an_invalid_line(capsys, run, tmp_path):
    """Valid JSON (an escape), but no text: the report could not write it."""
    append_line(run, {**first_line(run), "model": "greedy\ud800"})
    code, _, err = cocobench(capsys, "report", run, "--out", tmp_path / "report", "--no-plots")
    assert code == 0, err
    assert "1 invalid result line skipped" in err


def test_score_names_an_agent_id_that_is_an_object(capsys, run):
    path = next(run.glob("episodes/greedy/D1_blind/*/trajectory.json"))
    document = json.loads(path.read_text())
    document["task_config"]["agents"][0]["id"] = {"x": 1}
    path.write_text(json.dumps(document))
    assert one_error(capsys, "score", path) == (f"cocobench: error: {path}: "
                                                "task_config.agents[0].id: not a string")


def test_score_names_a_field_it_reads_as_it_is(capsys, run):
    """A field of another type that the scorer does not check: named by what failed."""
    path = next(run.glob("episodes/greedy/D1_blind/*/trajectory.json"))
    document = json.loads(path.read_text())
    document["planner_decisions"][0]["status"] = ["action"]
    path.write_text(json.dumps(document))
    line = one_error(capsys, "score", path)
    assert line.startswith(f"cocobench: error: {path}: not a trajectory the scorer can read")
    assert "TypeError: unhashable type: 'list'" in line


def test_score_refuses_a_lone_surrogate(capsys, run):
    path = next(run.glob("episodes/greedy/D1_blind/*/trajectory.json"))
    document = json.loads(path.read_text())
    document["task_id"] = "\udc00"
    path.write_text(json.dumps(document))
    assert one_error(capsys, "score", path) == (
        f"cocobench: error: {path}: not text: a lone surrogate (\\udc00) that no UTF-8 file "
        "can hold")


@pytest.mark.parametrize("field", ["conditions", "planners"])
def test_resume_never_runs_a_planner_the_run_folder_names(capsys, run, canary, monkeypatch,
                                                         field):
    """A run.json naming the canary as its planner: the resumed run stops before loading
    it, and says how to run it (name it again)."""
    monkeypatch.chdir(run)
    reference = f"{CANARY_FILE}:build_x" + ("_blind" if field == "conditions" else "")
    edit_record(run, lambda record: record["request"].update(
        {field: [reference], **({"conditions": None} if field == "planners" else {})}))
    line = one_error(capsys, "run", "--out", run, "--resume")
    assert f"the recorded run's planners are code ({reference})" in line
    assert f"give --{'conditions' if field == 'conditions' else 'planner'} {reference}" in line
    assert not canary.exists()


def test_resume_never_runs_a_condition_of_a_result_line(capsys, run, canary, monkeypatch):
    # A marker of this test's own: under xdist the folder above holds other tests' folders,
    # and a viewer export may rightly hold a page slugged from their 'ESCAPED' ids.
    marker = f"ESCAPED-{uuid.uuid4().hex}"
    monkeypatch.chdir(run)
    append_line(run, {**first_line(run), "condition": f"{CANARY_FILE}:build_x_blind",
                      "task_id": f"../../../../{marker}"})
    code, _, err = cocobench(capsys, "run", "--out", run, "--resume")
    assert code == 0, err
    assert not canary.exists()
    assert not list(run.parent.parent.rglob(f"{marker}*"))


def _report_command(run: Path, out: Path) -> list[str]:
    return [sys.executable, "-m", "cocobench_agents.cli", "report", str(run), "--out", str(out),
            "--resamples", "20"]


def test_a_report_that_cannot_be_written_is_one_line(run, tmp_path):
    """A full disk, as a file size limit makes it (EFBIG), in a real process."""
    def small_files() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # fail the write, not the process
        resource.setrlimit(resource.RLIMIT_FSIZE, (512, 512))

    out = tmp_path / "report"
    done = subprocess.run(_report_command(run, out), capture_output=True, text=True, cwd=ROOT,
                          timeout=120, preexec_fn=small_files)
    assert done.returncode == 1, done.stderr
    assert done.stderr.startswith(f"Error: cannot write {out}/"), done.stderr
    assert "File too large" in done.stderr and "Traceback" not in done.stderr


def _mount(path: Path, *options: str) -> None:
    path.mkdir(exist_ok=True)
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", ",".join(options), "tmpfs", str(path)],
                          capture_output=True, text=True)
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here ({done.stderr.strip()})")


@pytest.mark.parametrize(("options", "says"), [
    (("size=64k",), "No space left on device"), (("ro",), "Read-only file system")])
def test_a_report_on_a_full_or_read_only_disk_is_one_line(run, tmp_path, options, says):
    """A real full disk and a real read-only one (a small tmpfs; needs the right to mount)."""
    disk = tmp_path / "disk"
    _mount(disk, *options)
    try:
        done = subprocess.run(_report_command(run, disk / "report"), capture_output=True,
                              text=True, cwd=ROOT, timeout=120)
    finally:
        subprocess.run(["umount", str(disk)], check=True)
    assert done.returncode == 1, done.stderr
    assert done.stderr.startswith(f"Error: cannot write {disk / 'report'}"), done.stderr
    assert says in done.stderr and "Traceback" not in done.stderr


def test_a_report_into_a_read_only_run_folder_is_one_line(run, tmp_path):
    """The default report folder (RUN/report) in a run folder the user cannot write."""
    if os.geteuid() == 0:  # root writes anyway: the run is copied onto a read-only disk
        disk = tmp_path / "disk"
        _mount(disk, "size=4m")
        shutil.copytree(run, disk / "run")
        subprocess.run(["mount", "-o", "remount,ro", str(disk)], check=True)
        run = disk / "run"
    else:
        run.chmod(0o555)
    try:
        done = subprocess.run([sys.executable, "-m", "cocobench_agents.cli", "report", str(run),
                               "--no-plots"], capture_output=True, text=True, cwd=ROOT,
                              timeout=120)
    finally:
        if os.geteuid() == 0:
            subprocess.run(["umount", str(tmp_path / "disk")], check=True)
        else:
            run.chmod(0o755)
    assert done.returncode == 1, done.stderr
    assert done.stderr.startswith(f"Error: cannot write {run / 'report'}"), done.stderr
    assert "Traceback" not in done.stderr


@pytest.mark.slow
@pytest.mark.needs_inspect
def test_import_inspect_never_runs_a_planner_the_log_names(capsys, tmp_path, run, canary):
    """An Inspect log of the task whose recorded request names the canary as its condition:
    the import stops in one line before anything is loaded or written."""
    from inspect_ai import eval as inspect_eval
    from inspect_ai.log import write_eval_log

    from cocobench_agents.inspect_eval.task import REQUEST, cocobench
    from tests.inspect_eval.conftest import scripted_mockllm

    [log] = inspect_eval(cocobench(task=[str(SHARED_TASKS / "A_D1__FloorPlan1__seed0.json")],
                                   conditions="C0_blind", max_steps=2),
                         model=scripted_mockllm(["ACTION: 0"]), display="none",
                         log_dir=str(tmp_path / "logs"))
    reference = f"{run / CANARY_FILE}:build_x_blind"
    log.eval.metadata[REQUEST]["conditions"] = [reference]
    shared = tmp_path / "shared.eval"
    write_eval_log(log, str(shared))
    line = one_error(capsys, "import-inspect", shared, "--out", tmp_path / "imported")
    assert line == (f"cocobench: error: {shared}: the task ran planners that are code "
                    f"({reference}), which import-inspect never loads from a log")
    assert not canary.exists() and not (tmp_path / "imported").exists()


@pytest.mark.needs_export
def test_export_reads_a_decision_whose_seat_and_status_are_lists(capsys, run, tmp_path):
    """Found by the property test: a decision's `agent` (and `status`) that is a list made
    the export's own keys unhashable (a TypeError traceback)."""
    path = next(run.glob("episodes/greedy/D1_blind/*/trajectory.json"))
    document = json.loads(path.read_text())
    document["planner_decisions"][2].update(agent=[["agent_1"]], status=["action"])
    path.write_text(json.dumps(document, indent=2))
    code, _, err = cocobench(capsys, "export", run, "--out", tmp_path / "dataset")
    assert code == 0, err
