"""`RetryPolicy`: tenacity retries of transient failures, applied by the decide node, with the
run-level options as defaults and replaceable by a strategy."""

from __future__ import annotations

import asyncio
import dataclasses
import time

import pytest

from benchmark_adapter.tasks import load_tasks
from cocobench_agents.episode_runner import EpisodeSpec, run_episode
from cocobench_agents.graphs import PLANNERS
from cocobench_agents.models import ModelError, ModelReply, ModelRequest, ModelSettings, RetryPolicy

REQUEST = ModelRequest(prompt="Pick an action.")


class Flaky:
    """A client failing its first `failures` attempts (transiently unless told otherwise)."""

    def __init__(self, failures: int, *, transient: bool = True, retry_after_s=None,
                 text: str = "REASON: ok\nACTION: 1") -> None:
        self.name = "flaky"
        self.failures, self.transient, self.retry_after_s = failures, transient, retry_after_s
        self.text = text
        self.attempts: list[tuple[int, float]] = []

    async def attempt(self, request: ModelRequest, number: int) -> ModelReply:
        self.attempts.append((number, time.perf_counter()))
        if len(self.attempts) <= self.failures:
            raise ModelError("rate_limit" if self.transient else "bad_request", "no",
                             extra={"prompt_tokens": 5, "cost_usd": 0.5},
                             transient=self.transient, retry_after_s=self.retry_after_s)
        return ModelReply(text=self.text, prompt_tokens=10, completion_tokens=2, cost_usd=1.0)

    async def complete(self, request: ModelRequest) -> ModelReply:
        return await RetryPolicy().complete(self, request)


FAST = RetryPolicy(max_attempts=3, backoff_s=0.001, backoff_max_s=0.002)


def test_transient_failures_are_retried_and_accounted():
    client = Flaky(2)
    reply = asyncio.run(FAST.complete(client, REQUEST))
    assert [n for n, _ in client.attempts] == [1, 2, 3]
    assert reply.retries == 2
    # every attempt that got an answer is billed: two failed (5 tokens, $0.5 each) + the reply
    assert (reply.prompt_tokens, reply.completion_tokens, reply.cost_usd) == (20, 2, 2.0)


def test_exhausted_attempts_give_the_last_error_with_the_count():
    client = Flaky(5)
    with pytest.raises(ModelError) as info:
        asyncio.run(FAST.complete(client, REQUEST))
    err = info.value
    assert len(client.attempts) == 3
    assert err.kind == "rate_limit" and err.retries == 2
    assert err.message.endswith("(after 3 attempts)")
    assert err.extra["attempts"] == 3 and err.extra["prompt_tokens"] == 15


def test_a_permanent_error_is_not_retried():
    client = Flaky(1, transient=False)
    with pytest.raises(ModelError) as info:
        asyncio.run(FAST.complete(client, REQUEST))
    assert len(client.attempts) == 1
    assert info.value.retries == 0 and "attempt" not in info.value.message


def test_retry_after_sets_the_least_pause():
    client = Flaky(1, retry_after_s=0.2)
    asyncio.run(RetryPolicy(max_attempts=2, backoff_s=0.0, backoff_max_s=5).complete(
        client, REQUEST))
    (_, first), (_, second) = client.attempts
    assert second - first >= 0.19


def test_retry_after_is_capped_by_the_backoff_ceiling():
    client = Flaky(1, retry_after_s=60)
    started = time.perf_counter()
    asyncio.run(RetryPolicy(max_attempts=2, backoff_s=0.0, backoff_max_s=0.05).complete(
        client, REQUEST))
    assert time.perf_counter() - started < 1


def test_the_run_level_options_are_the_default_policy():
    settings = ModelSettings(max_retries=4, backoff_s=0.5, backoff_max_s=7)
    assert RetryPolicy.from_settings(settings) == RetryPolicy(5, 0.5, 7)


def test_clients_without_attempts_are_asked_once():
    class Once:
        name = "once"
        calls = 0

        async def complete(self, request):
            Once.calls += 1
            return ModelReply(text="ACTION: 1")

    assert asyncio.run(FAST.complete(Once(), REQUEST)).text == "ACTION: 1"
    assert Once.calls == 1


class FlakyPool:
    """A client factory whose model fails transiently `failures` times, then picks id 1."""

    def __init__(self, failures: int, settings: ModelSettings) -> None:
        self.settings = settings
        self.flaky = Flaky(failures, text="REASON: first\nACTION: 1")

    def client(self, spec, *, episode, agent):
        return self.flaky

    def release(self, episode):
        pass


def _first_decision(spec: EpisodeSpec, pool: FlakyPool) -> dict:
    document, _ = asyncio.run(run_episode(spec, pool))
    return next(d for d in document["planner_decisions"] if d.get("status") != "plan")


@pytest.fixture()
def spec():
    config = load_tasks("demo")[0]
    return EpisodeSpec(config, planner="centralized", models={"*": "flaky"},
                       obs_mode="blind", max_steps=1)


def test_the_decide_node_applies_the_run_level_policy(spec):
    fast = ModelSettings(max_retries=2, backoff_s=0.001, backoff_max_s=0.002)
    decision = _first_decision(spec, FlakyPool(2, fast))
    assert decision["status"] == "action" and decision["retries"] == 2
    decision = _first_decision(spec, FlakyPool(2, ModelSettings(max_retries=1, backoff_s=0)))
    assert decision["status"] == "backend_error" and decision["retries"] == 1


def test_a_strategy_can_replace_the_policy(spec, monkeypatch):
    strict = dataclasses.replace(PLANNERS["centralized"], name="strict",
                                 retry_policy=RetryPolicy(max_attempts=1))
    monkeypatch.setitem(PLANNERS, "strict", strict)
    spec = dataclasses.replace(spec, planner="strict")
    fast = ModelSettings(max_retries=5, backoff_s=0.001, backoff_max_s=0.002)
    decision = _first_decision(spec, FlakyPool(1, fast))
    assert decision["status"] == "backend_error" and decision["retries"] == 0
