"""`cocobench report`: files printed, clear errors with exit code 2, no traceback."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from cocobench_agents.cli.report_cmd import report_command

from .helpers import NOT_RUN_FOLDERS, RUN_ORACLE, RUN_SMALL, not_a_run_folder


def invoke(*args: str):
    result = CliRunner().invoke(report_command, list(args))
    assert "Traceback" not in result.output
    return result


def test_writes_and_prints_the_files(tmp_path: Path) -> None:
    out = tmp_path / "rep"
    result = invoke(str(RUN_SMALL), str(RUN_ORACLE), "--out", str(out), "--no-plots",
                    "--resamples", "200")
    assert result.exit_code == 0, result.output
    printed = [line for line in result.stdout.splitlines() if line.strip()]
    assert printed[0] == str(out / "index.md")
    assert str(out / "main_results.md") in printed and str(out / "main_results.csv") in printed
    assert all(Path(p).exists() for p in printed)
    assert "52 episodes, 3 model(s), 7 condition(s)" in result.stderr
    assert "200 resamples" in (out / "index.md").read_text(encoding="utf-8")


def test_default_out_is_inside_the_first_run(small_copy: Path) -> None:
    result = invoke(str(small_copy), "--no-plots")
    assert result.exit_code == 0, result.output
    assert (small_copy / "report" / "index.md").exists()


@pytest.mark.parametrize("make", NOT_RUN_FOLDERS)
def test_not_a_run_folder_is_a_usage_error(tmp_path: Path, make: str) -> None:
    path = not_a_run_folder(tmp_path / "nope", make)
    result = invoke(str(RUN_SMALL), str(path), "--out", str(tmp_path / "rep"))
    assert result.exit_code == 2
    assert str(path) in result.output and "run folder" in result.output
    assert not (tmp_path / "rep").exists()  # checked before anything is written


def test_unknown_plot_condition_is_a_usage_error(tmp_path: Path) -> None:
    result = invoke(str(RUN_SMALL), "--out", str(tmp_path / "rep"), "--plot-condition", "X")
    assert result.exit_code == 2 and "no episodes under it" in result.output


def test_registered_in_the_cocobench_command(capsys, tmp_path: Path) -> None:
    from cocobench_agents.cli import main

    assert main(["report", str(tmp_path / "missing")]) == 2
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err and "no such run folder" in err


@pytest.mark.slow
def test_arms_are_counted_as_arms_not_as_models(capsys, tmp_path: Path) -> None:
    from cocobench_agents.cli import main

    two_arms, plain = tmp_path / "arms", tmp_path / "plain"
    common = ["run", "--suite", "demo", "--limit", "1", "--model", "greedy"]
    assert main([*common, "--prompt-suite", "cocobench-v1", "--prompt-suite",
                 "cocobench-v1+no-hint", "--out", str(two_arms)]) == 0
    assert main([*common, "--out", str(plain)]) == 0
    capsys.readouterr()

    assert main(["report", str(two_arms), "--out", str(tmp_path / "rep"), "--no-plots",
                 "--resamples", "50"]) == 0
    assert "2 episodes, 1 model(s), 2 arm(s), 1 condition(s)" in capsys.readouterr().err
    index = (tmp_path / "rep" / "index.md").read_text(encoding="utf-8")
    assert "2 episodes of 1 model(s) in 2 arm(s) under 1 condition(s)" in index
    assert "* Models: greedy\n* Arms: cocobench-v1, cocobench-v1+no-hint\n" in index
    assert "| greedy; arms: cocobench-v1, cocobench-v1+no-hint |" in index

    # runs reported as arms (--arms): still one model
    assert main(["report", str(plain), str(two_arms), "--arms", "--out",
                 str(tmp_path / "rep2"), "--no-plots", "--resamples", "50"]) == 0
    assert "3 episodes, 1 model(s), 3 arm(s), 1 condition(s)" in capsys.readouterr().err
