"""Spend limits (--max-cost, --max-total-tokens) stop starting episodes and leave a folder that
--resume with a higher limit completes; --episode-timeout ends a runaway episode as an
infrastructure error."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from cocobench_agents.cli import main
from tests.models.fake_openai import FakeOpenAI, ok

# The fake server bills 11 prompt + 7 completion tokens per call.
RUN = ["run", "--model", "openai/fake-model", "--suite", "demo", "--max-steps", "3",
       "--jobs", "1", "--transport", "http"]


def results(out: Path) -> list[dict]:
    return [json.loads(line) for line in (out / "results.jsonl").read_text().splitlines()]


@pytest.fixture
def server():
    with FakeOpenAI(default=ok("REASON: go\nACTION: 1")) as fake:
        yield fake


EXECUTORS = [["--workers", "1"], ["--workers", "2"],
             pytest.param(["--executor", "ray", "--workers", "1"],
                          marks=[pytest.mark.slow, pytest.mark.needs_ray])]


@pytest.mark.parametrize("executor", EXECUTORS, ids=["local", "workers", "ray"])
def test_a_token_limit_stops_new_episodes_and_resume_completes(tmp_path, capsys, server,
                                                               executor):
    out = tmp_path / "run"
    argv = [*RUN, "--api-base", server.base_url, *executor, "--out", str(out)]
    assert main([*argv, "--max-total-tokens", "40"]) == 3
    err = capsys.readouterr().err
    assert "spend limit reached" in err and "--resume --max-total-tokens" in err
    stopped = results(out)
    assert 1 <= len(stopped) < 4
    assert main(["run", "--out", str(out), "--resume", "--max-total-tokens", "100000"]) == 0
    assert len(results(out)) == 4


def test_a_cost_limit_counts_what_the_folder_already_spent(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["run", "--model", "greedy", "--suite", "demo", "--limit", "2", "--out",
                 str(out)]) == 0
    lines = (out / "results.jsonl").read_text().splitlines()
    spent = [json.loads(line) for line in lines]
    spent[0]["usage"] = {**(spent[0].get("usage") or {}), "cost_usd": 5.0}
    (out / "results.jsonl").write_text(json.dumps(spent[0]) + "\n")  # one done, $5 spent
    assert main(["run", "--out", str(out), "--resume", "--max-cost", "1"]) == 3
    assert len(results(out)) == 1
    assert "$5.0000 of --max-cost 1" in capsys.readouterr().err


@pytest.mark.parametrize("executor", [[], pytest.param(["--executor", "ray"], marks=[
    pytest.mark.slow, pytest.mark.needs_ray])], ids=["local", "ray"])
def test_a_runaway_episode_ends_as_an_infrastructure_error(tmp_path, server, executor):
    server.program(default=ok("REASON: slow\nACTION: 1", delay_s=1.0))
    out = tmp_path / "run"
    code = main([*RUN, "--limit", "1", "--max-steps", "20", "--api-base", server.base_url,
                 "--episode-timeout", "0.5", *executor, "--out", str(out)])
    (record,) = results(out)
    assert "timed out after 0.5 s" in record["infra_error"]
    assert record["task_success"] == 0
    assert code == 1  # counted as an error, not as the model's failure
