"""Fault injection through whole episodes, for each transport: a local OpenAI-compatible
server answers 429, 500, too slowly, empty, malformed and oversized. Retries happen for
transient errors only, each episode records what happened and ends with the right terminal
reason, nothing crashes, the other episodes of the batch are unaffected, and the API key is
written nowhere."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from benchmark_adapter.tasks import load_tasks
from cocobench_agents.harness import (
    Condition,
    ExecutionSettings,
    InProcess,
    plan_episodes,
)
from cocobench_agents.models import ENDPOINT_TRANSPORTS, ModelPool, ModelSettings
from cocobench_agents.runfolder import RunFolder
from tests.models.fake_openai import (
    RATE_LIMITED,
    SERVER_ERROR,
    Behaviour,
    FakeOpenAI,
    completion_body,
    ok,
)

FAKE_KEY = "sk-fake-cocobench-do-not-leak-4242"
HEALTHY = "REASON: the task looks done\nACTION: DONE"


class ByModel(FakeOpenAI):
    """Answers each model name with its own script, so faulty and healthy episodes share one
    server (and one batch)."""

    def __init__(self, scripts: dict[str, list[Behaviour]], default: Behaviour) -> None:
        super().__init__(default)
        self.scripts = {name: list(s) for name, s in scripts.items()}
        self.calls: dict[str, int] = {}

    def _next(self, body, headers):
        super()._next(body, headers)
        name = body.get("model", "")
        self.calls[name] = self.calls.get(name, 0) + 1
        script = self.scripts.get(name)
        return script.pop(0) if script else self.default


SCRIPTS = {
    # model name → replies, then the default (a healthy DONE)
    "rate-limited": [RATE_LIMITED],
    "always-500": [SERVER_ERROR] * 20,
    "too-slow": [ok(HEALTHY, delay_s=3.0)] * 20,
    "empty": [Behaviour(200, completion_body(""))] * 20,
    "malformed": [ok("I would rather not say.")],
    "oversized": [ok("REASON: " + "blah " * 20_000 + "\nACTION: DONE")],
}
EXPECTED = {
    # model → (terminal reason, whether its one model call was retried)
    "rate-limited": ("done", True),  # 429 retried, then DONE
    "always-500": ("backend_error", True),  # retried until given up
    "too-slow": ("backend_error", True),
    "empty": ("backend_error", True),  # an empty completion counts as transient
    "malformed": ("parse_error", False),  # no retry for a parse error, no re-prompt
    # Cut before its ACTION line: what remains has no number, so nothing to parse (the fact
    # of the cut is recorded beside the text, never parsed as part of it).
    "oversized": ("parse_error", False),
    "healthy": ("done", False),
}


@pytest.fixture(params=ENDPOINT_TRANSPORTS)
def batch(request, tmp_path: Path, monkeypatch) -> tuple[RunFolder, ByModel]:
    monkeypatch.setenv("FAKE_PROVIDER_API_KEY", FAKE_KEY)
    config = next(c for c in load_tasks("demo") if c.cell == "G_D1")
    with ByModel(SCRIPTS, ok(HEALTHY)) as server:
        settings = ModelSettings(api_base=server.base_url, api_key_env="FAKE_PROVIDER_API_KEY",
                                 timeout_s=0.5, max_retries=2, backoff_s=0.01,
                                 backoff_max_s=0.02, max_reply_chars=4_000,
                                 transport=request.param)
        models = [f"openai/{name}" for name in EXPECTED]
        episodes = plan_episodes([config], models, [Condition("centralized", "blind")], 1)
        folder = RunFolder(tmp_path / "run")
        folder.create({"name": "faults"})
        InProcess().run(episodes, folder, ModelPool(settings), ExecutionSettings(jobs=4))
        yield folder, server


def test_each_fault_ends_its_episode_with_the_right_reason(batch):
    folder, server = batch
    results = {r["model"].removeprefix("openai/"): r for r in folder.results()}
    assert set(results) == set(EXPECTED)
    for name, (reason, retried) in EXPECTED.items():
        assert "infra_error" not in results[name], name
        assert results[name]["terminal_reason"] == reason, name
        retries = results[name]["usage"]["retries"]
        assert (retries > 0) == retried, name
        assert (server.calls[name] > 1) == retried, name  # retries reached the server again
        if reason == "backend_error":
            assert retries == 2, name  # all attempts used: 1 + max_retries


def test_decisions_record_what_happened(batch):
    folder, _ = batch
    decisions = {}
    for record in folder.results():
        document = json.loads((folder.path / record["trajectory"]).read_text())
        decisions[record["model"].removeprefix("openai/")] = document["planner_decisions"][0]
    assert decisions["always-500"]["error_kind"] == "transient"
    assert decisions["too-slow"]["error_kind"] == "timeout"
    assert decisions["empty"]["error_kind"] == "empty"
    assert decisions["malformed"]["raw_output"] == "I would rather not say."
    assert decisions["oversized"]["raw_output"] == ("REASON: " + "blah " * 20_000)[:4_000]
    assert decisions["oversized"]["reply_truncated_chars"] == 100_021 - 4_000
    assert "reply_truncated_chars" not in decisions["malformed"]


def test_the_api_key_is_written_nowhere(batch):
    folder, server = batch
    assert any(FAKE_KEY in h.get("authorization", "") for h in server.headers)  # it was used
    for path in folder.path.rglob("*"):
        if path.is_file():
            assert FAKE_KEY not in path.read_text(encoding="utf-8", errors="replace"), path
