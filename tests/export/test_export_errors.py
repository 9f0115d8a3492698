"""The unhappy paths of `cocobench export`: every mistake is one line naming the path or the
`--where` at fault (exit code 2, nothing written); a folder that cannot be written is exit
code 1 with what was written removed; what a run holds that cannot be exported (a torn last
line, infrastructure failures, planner errors) is said, not silently dropped."""

from __future__ import annotations

import json
import os
import resource
import signal
import subprocess
import sys
import zlib
from pathlib import Path

import pytest

from cocobench_agents.runfolder import RunLock
from tests.export.helpers import DATA, episode_of, export, load, model_decisions, result_lines

ROOT = Path(__file__).resolve().parents[2]


def one_error(capsys, *args) -> str:
    """The one error line of an export that must fail as a user mistake."""
    code, out, err = export(capsys, *args)
    assert (code, out) == (2, ""), err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("cocobench: error: "), err
    return lines[0]


def test_paths_that_are_not_finished_run_folders(capsys, played_run, tmp_path):
    out = tmp_path / "ds"
    assert f"{tmp_path / 'nope'}: no such run folder" in one_error(
        capsys, tmp_path / "nope", "--out", out)
    (tmp_path / "file").write_text("x")
    assert "file: not a run folder (a file" in one_error(capsys, tmp_path / "file",
                                                         "--out", out)
    (tmp_path / "empty").mkdir()
    assert "empty: not a run folder (no run.json" in one_error(capsys, tmp_path / "empty",
                                                               "--out", out)
    assert "given twice" in one_error(capsys, played_run, str(played_run) + "/", "--out", out)
    assert not out.exists()


def test_a_run_in_progress_is_refused_naming_its_process(capsys, run_copy, tmp_path):
    with RunLock(run_copy):  # as `cocobench run` holds it for the whole run
        error = one_error(capsys, run_copy, "--out", tmp_path / "ds")
    assert f"is in use by another cocobench run (pid {os.getpid()})" in error
    assert "export it once the run has ended" in error
    assert not (tmp_path / "ds").exists()


@pytest.mark.parametrize(("where", "says"), [
    ("winning", "unknown selector; use one of: success, failure, legal, illegal, "
                "condition=VALUE"),
    ("success=1", "success takes no value"),
    ("condition", "condition needs a value"),
    ("model=", "no value after '='"),
    ("condition=Z9_blind", "no episode passes --where condition=Z9_blind (the runs hold "
                           "condition: C0_blind, C0_image, D0_blind, D1_blind, D1_image)"),
])
def test_where_mistakes(capsys, played_run, tmp_path, where, says):
    assert says in one_error(capsys, played_run, "--out", tmp_path / "ds", "--where", where)
    assert not (tmp_path / "ds").exists()


def test_an_output_folder_in_use_is_refused_and_left_as_it_was(capsys, played_run, tmp_path):
    out = tmp_path / "ds"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    assert "the output folder exists and is not empty" in one_error(capsys, played_run,
                                                                     "--out", out)
    assert [p.name for p in out.iterdir()] == ["notes.txt"]
    assert "exists and is not empty" in one_error(capsys, played_run, "--out",
                                                  out / "notes.txt")


@pytest.mark.needs_export
def test_a_damaged_trajectory_is_named(capsys, run_copy, tmp_path):
    line = result_lines(run_copy)[3]
    # Whole to the end (a file cut short counts as not done: `--resume` runs it again), but
    # not JSON.
    (run_copy / line["trajectory"]).write_text("{not json\n}")
    error = one_error(capsys, run_copy, "--out", tmp_path / "ds")
    assert f"{run_copy / line['trajectory']}: unreadable" in error
    assert not (tmp_path / "ds").exists()  # what it had written is removed


@pytest.mark.slow
@pytest.mark.needs_export
def test_prompts_inflating_past_the_bound_are_named_not_read(capsys, run_copy, tmp_path):
    """A `prompts.json.gz` of 300 KB that inflates to 300 MiB (a compression bomb in a shared
    run folder) is refused at 256 MiB, naming the file: it was inflated whole into memory."""
    line = result_lines(run_copy)[3]
    bomb = zlib.compressobj(9, zlib.DEFLATED, zlib.MAX_WBITS | 16)  # gzip
    zeros = bytes(2**20)
    prompts = (run_copy / line["trajectory"]).parent / "prompts.json.gz"
    prompts.write_bytes(b"".join(bomb.compress(zeros) for _ in range(300)) + bomb.flush())
    error = one_error(capsys, run_copy, "--out", tmp_path / "ds")
    assert error.endswith(f"{prompts}: unreadable (inflates past 256 MiB)"), error
    assert not (tmp_path / "ds").exists()


def test_without_pyarrow_the_error_names_the_install(played_run, tmp_path):
    code = ("import sys; sys.modules['pyarrow'] = None\n"
            "from cocobench_agents.cli import main\n"
            f"sys.exit(main(['export', {str(played_run)!r}, '--out', {str(tmp_path / 'd')!r}]))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=ROOT, timeout=120)
    assert done.returncode == 2, done.stderr
    assert done.stderr == ("cocobench: error: cocobench export writes Parquet with pyarrow, "
                           "which is not installed: pip install 'cocobench-agents[export]'\n")
    assert not (tmp_path / "d").exists()


@pytest.mark.needs_export
def test_a_full_disk_is_exit_1_and_leaves_nothing(played_run, tmp_path):
    """A file size limit makes the Parquet writer fail as a full disk does (EFBIG)."""
    def small_files() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # fail the write, not the process
        resource.setrlimit(resource.RLIMIT_FSIZE, (4096, 4096))

    out = tmp_path / "ds"
    done = subprocess.run([sys.executable, "-m", "cocobench_agents.cli", "export",
                           str(played_run), "--out", str(out)], capture_output=True,
                          text=True, cwd=ROOT, timeout=120, preexec_fn=small_files)
    assert done.returncode == 1, done.stderr
    assert done.stderr.startswith(f"Error: cannot write {out / DATA}: "), done.stderr
    assert "File too large" in done.stderr  # pyarrow's words around the system's
    assert "Traceback" not in done.stderr
    assert not out.exists()


@pytest.mark.needs_export
def test_an_output_folder_that_cannot_be_made_is_exit_1(capsys, played_run, tmp_path):
    (tmp_path / "file").write_text("x")
    code, _, err = export(capsys, played_run, "--out", tmp_path / "file" / "ds")
    assert code == 1
    assert err.startswith(f"Error: cannot create {tmp_path / 'file' / 'ds' / 'data'}: ")


@pytest.mark.needs_export
def test_a_torn_last_line_is_skipped_and_said(capsys, run_copy, tmp_path):
    """A run killed in mid-write: its last, incomplete line is not an episode."""
    results = run_copy / "results.jsonl"
    lines = results.read_text().splitlines(keepends=True)
    torn = json.loads(lines[-1])
    results.write_text("".join(lines[:-1]) + lines[-1][: len(lines[-1]) // 2])
    code, _, err = export(capsys, run_copy, "--out", tmp_path / "ds")
    assert code == 0
    assert f"warning: {results}: its last line is incomplete" in err
    assert f"cocobench run --out {run_copy} --resume" in err
    rows = load(tmp_path / "ds", tmp_path / "cache")
    assert episode_of(torn) not in {episode_of(r) for r in rows}
    kept = result_lines_of(lines[:-1])
    assert len(rows) == sum(len(model_decisions(run_copy, line)) for line in kept)


def result_lines_of(lines: list[str]) -> list[dict]:
    return [json.loads(line) for line in lines]


@pytest.mark.needs_export
def test_infrastructure_failures_are_left_out_unless_asked(capsys, run_copy, tmp_path):
    results = run_copy / "results.jsonl"
    lines = result_lines(run_copy)
    lines[0]["backend_errors"] = 1  # a model call that got no answer after retries
    results.write_text("".join(json.dumps(line) + "\n" for line in lines))
    failed = episode_of(lines[0])

    code, _, err = export(capsys, run_copy, "--out", tmp_path / "a")
    assert code == 0
    assert "warning: left out: 1 infrastructure-failure episode(s) (--include-infra keeps " \
           "them)" in err
    assert failed not in {episode_of(r) for r in load(tmp_path / "a", tmp_path / "cache")}
    assert "left out: 1 infrastructure-failure" in (tmp_path / "a" / "README.md").read_text()

    code, _, err = export(capsys, run_copy, "--out", tmp_path / "b", "--include-infra")
    assert code == 0, err
    rows = load(tmp_path / "b", tmp_path / "cache")
    assert {episode_of(r) for r in rows if r["infra_failure"]} == {failed}
    assert one_error(capsys, run_copy, "--out", tmp_path / "c", "--where",
                     f"task_id={failed[2]}", "--where", f"model={failed[0]}", "--where",
                     f"condition={failed[1]}").endswith(
        "every selected episode (1) is an infrastructure failure; pass --include-infra to "
        "export them anyway")


@pytest.mark.needs_export
def test_planner_errors_are_left_out_as_not_the_models_decisions(capsys, run_copy, tmp_path):
    """An episode the strategy's own code ended (`planner_error`) is not training data of the
    model: left out, counted in a warning and in the card, even with --include-infra."""
    results = run_copy / "results.jsonl"
    lines = result_lines(run_copy)
    lines[0]["planner_error"] = "ValueError: boom in node 'act' (strategy.py, line 9)"
    results.write_text("".join(json.dumps(line) + "\n" for line in lines))
    failed = episode_of(lines[0])

    for out, flags in ((tmp_path / "a", ()), (tmp_path / "b", ("--include-infra",))):
        code, _, err = export(capsys, run_copy, "--out", out, *flags)
        assert code == 0, err
        assert "warning: left out: 1 planner-error episode(s) (the strategy's own code " \
               "failed; fix it and run them again)" in err
        assert failed not in {episode_of(r) for r in load(out, tmp_path / "cache")}
        assert "left out: 1 planner-error" in (out / "README.md").read_text()
    assert one_error(capsys, run_copy, "--out", tmp_path / "c", "--where",
                     f"task_id={failed[2]}", "--where", f"model={failed[0]}", "--where",
                     f"condition={failed[1]}").endswith(
        "every selected episode (1) is a planner error (the strategy's own code failed): "
        "nothing to export")


def test_export_is_listed_and_loads_nothing_optional():
    code = ("import sys, cocobench_agents, cocobench_agents.export\n"
            "from cocobench_agents.cli import COMMANDS, SUMMARIES\n"
            "assert 'export' in COMMANDS and 'export' in SUMMARIES\n"
            "assert 'pyarrow' not in sys.modules and 'datasets' not in sys.modules, 'loaded'\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=ROOT, timeout=120)
    assert done.returncode == 0, done.stderr
