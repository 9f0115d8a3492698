"""`--resume` keeps the recorded settings: a bare resume restores every option, an explicit one
that changes what is sent or scored is refused, sources are absolute; run.json holds no
credential given inline (--extra, URL user:password)."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from cocobench_agents.cli import main
from tests.models.fake_openai import FakeOpenAI, ok

DEMO = ["--suite", "demo", "--limit", "2"]
INLINE_KEY = "sk-inline-secret-7788"
URL_PASSWORD = "url-password-5566"


def results(out: Path) -> list[dict]:
    return [json.loads(line) for line in (out / "results.jsonl").read_text().splitlines()]


def forget_last_result(out: Path) -> None:
    lines = (out / "results.jsonl").read_text().splitlines(keepends=True)
    (out / "results.jsonl").write_text("".join(lines[:-1]))


def test_a_bare_resume_restores_the_recorded_options(tmp_path):
    out = tmp_path / "run"
    assert main(["run", "--model", "greedy", *DEMO, "--max-steps", "2", "--stable-ids",
                 "--prompt-suite", "cocobench-v1+no-hint", "--out", str(out)]) == 0
    forget_last_result(out)
    assert main(["run", "--out", str(out), "--resume"]) == 0
    rerun = results(out)[-1]
    assert rerun["num_steps"] <= 2
    assert rerun["prompt_suite"] == "cocobench-v1+no-hint"
    assert len(results(out)) == 2


@pytest.mark.parametrize("option", [
    ["--max-steps", "3"], ["--prompt-suite", "cocobench-v1"], ["--stable-ids"],
    ["--temperature", "0.7"], ["--grammar"], ["--epochs", "2"], ["--model", "random"],
    ["--extra", '{"top_p": 0.5}'],
])
def test_a_conflicting_option_is_refused_naming_it(tmp_path, capsys, option):
    out = tmp_path / "run"
    assert main(["run", "--model", "greedy", *DEMO, "--max-steps", "2",
                 "--prompt-suite", "cocobench-v1+no-hint", "--out", str(out)]) == 0
    before = (out / "results.jsonl").read_text()
    capsys.readouterr()
    assert main(["run", "--out", str(out), "--resume", *option]) == 2
    err = capsys.readouterr().err
    assert option[0] in err and "recorded" in err and "Traceback" not in err
    assert (out / "results.jsonl").read_text() == before  # nothing recorded is lost


def test_options_of_how_a_run_goes_may_change(tmp_path):
    out = tmp_path / "run"
    assert main(["run", "--model", "greedy", *DEMO, "--jobs", "1", "--out", str(out)]) == 0
    forget_last_result(out)
    assert main(["run", "--out", str(out), "--resume", "--jobs", "4", "--timeout", "30"]) == 0
    assert len(results(out)) == 2


def test_a_relative_task_source_resumes_from_another_directory(tmp_path, monkeypatch):
    configs = Path(__file__).resolve().parents[2] / "benchmark_adapter" / "data" / "demo"
    work = tmp_path / "work"
    work.mkdir()
    os.symlink(configs, work / "configs")
    monkeypatch.chdir(work)
    assert main(["run", "--model", "greedy", "--task", "configs", "--limit", "2",
                 "--out", "run"]) == 0
    recorded = json.loads((work / "run" / "run.json").read_text())
    assert all(Path(p).is_absolute() for p in recorded["request"]["selection"]["sources"])
    forget_last_result(work / "run")
    monkeypatch.chdir(tmp_path)
    assert main(["run", "--out", str(work / "run"), "--resume"]) == 0
    assert len(results(work / "run")) == 2


@pytest.fixture
def server():
    with FakeOpenAI(default=ok("REASON: go\nACTION: 1")) as fake:
        yield fake


@pytest.mark.parametrize("transport", ["litellm", "http"])
def test_inline_credentials_never_reach_the_run_folder(tmp_path, capsys, server, transport):
    out = tmp_path / "run"
    base = server.base_url.replace("http://", f"http://user:{URL_PASSWORD}@")
    extra = json.dumps({"api_key": INLINE_KEY,
                        "extra_headers": {"Authorization": f"Bearer {INLINE_KEY}"}})
    argv = ["--model", "openai/fake-model", "--suite", "demo", "--limit", "1", "--max-steps",
            "2", "--api-base", base, "--extra", extra, "--transport", transport]
    assert main(["run", *argv, "--out", str(out)]) == 0
    assert server.count > 0  # the endpoint with credentials in its URL was reached
    written = "".join(p.read_text(errors="replace") for p in out.rglob("*") if p.is_file())
    assert INLINE_KEY not in written and URL_PASSWORD not in written
    assert INLINE_KEY not in capsys.readouterr().err
    # the recorded options cannot be replayed without the secrets: resume asks for them
    forget_last_result(out)
    assert main(["run", "--out", str(out), "--resume"]) == 2
    assert "give --" in capsys.readouterr().err
    assert main(["run", "--out", str(out), "--resume", "--api-base", base, "--extra",
                 extra]) == 0
    assert len(results(out)) == 1


def test_a_bare_resume_keeps_the_endpoint_and_transport(tmp_path, server):
    out = tmp_path / "run"
    assert main(["run", "--model", "openai/fake-model", "--suite", "demo", "--limit", "2",
                 "--max-steps", "2", "--api-base", server.base_url, "--transport", "http",
                 "--temperature", "0.3", "--out", str(out)]) == 0
    forget_last_result(out)
    server.program(default=ok("REASON: go\nACTION: 1"))
    assert main(["run", "--out", str(out), "--resume"]) == 0
    assert server.count > 0  # the same local endpoint, not the provider's default
    assert all(body.get("temperature") == 0.3 for body in server.requests)


def test_a_relative_suite_or_planner_given_again_is_the_same(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["prompts", "export", "cocobench-v1", "suite"]) == 0
    planner = Path(__file__).resolve().parents[1] / "planners" / "user_planner.py"
    (tmp_path / "mine.py").write_text(planner.read_text())
    name = next(line.split("(")[0].removeprefix("def ").strip()
                for line in planner.read_text().splitlines() if line.startswith("def build"))
    argv = ["--model", "greedy", *DEMO, "--prompt-suite", "./suite",
            "--planner", f"mine.py:{name}"]
    assert main(["run", *argv, "--out", "run"]) == 0
    forget_last_result(tmp_path / "run")
    assert main(["run", *argv, "--out", "run", "--resume"]) == 0
    assert len(results(tmp_path / "run")) == 2
