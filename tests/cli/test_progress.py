"""The run's progress display: rich's live bar on a terminal, plain lines elsewhere; both
show done/total, SR so far, errors, tokens, cost and the time left, over every episode of
the run (a resumed run's earlier ones too)."""

from __future__ import annotations

import io
import json

import pytest

from cocobench_agents.cli import main
from cocobench_agents.cli.progress import Progress

OK = {"model": "m", "condition": "C0_image", "task_id": "t1", "task_success": 1,
      "num_steps": 3, "usage": {"prompt_tokens": 1000, "completion_tokens": 200,
                                "cost_usd": 0.25}}
BROKEN = {"model": "m", "condition": "C0_image", "task_id": "t2", "task_success": 0,
          "infra_error": "ConnectionError()"}


class Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_plain_lines_off_a_terminal():
    stream = io.StringIO()
    progress = Progress(3, recorded=[{**OK, "task_id": "t0"}], stream=stream)
    progress.episode_done(OK)
    progress.episode_done(BROKEN)
    progress.close()
    lines = stream.getvalue().splitlines()
    assert lines[0].startswith("[2/3] m C0_image t1: success=1")
    assert lines[1] == "[3/3] m C0_image t2: ERROR ConnectionError()"
    # one total: the episode recorded before counts in SR, tokens and cost as in done
    assert lines[-1].startswith("3/3 done | SR 66.7% (2/3) | errors 1 | 2,400 tokens | "
                                "$0.5000 | ETA")
    assert "\x1b[" not in stream.getvalue()  # no terminal control codes in CI logs


def test_a_live_bar_on_a_terminal():
    stream = Terminal()
    progress = Progress(2, stream=stream)
    assert progress.live
    progress.episode_done(OK)
    progress.episode_done(BROKEN)
    progress.close()
    screen = stream.getvalue()
    assert "[1/2] m C0_image t1" in screen and "[2/2] m C0_image t2: ERROR" in screen
    assert "2/2" in screen and "SR 50.0% (1/2)" in screen and "errors 1" in screen
    assert "$0.2500" in screen and "ETA" in screen


@pytest.mark.slow
def test_a_resumed_run_counts_its_earlier_episodes(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["run", "--suite", "demo", "--limit", "2", "--planner", "oracle",
                 "--out", str(out)]) == 0
    results = out / "results.jsonl"
    first = results.read_text().splitlines(keepends=True)[0]
    results.write_text(first)  # as if killed after one episode
    capsys.readouterr()
    assert main(["run", "--out", str(out), "--resume"]) == 0
    err = capsys.readouterr().err
    assert json.loads(first)["task_success"] == 1
    assert "2 episodes (1 already done)" in err
    assert "2/2 done | SR 100.0% (2/2) | errors 0" in err  # not (1/1)
