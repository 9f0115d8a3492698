"""A LiteLLM model as a frozen partner: called as the ``COCOBENCH_RUN_*`` variables (or
`model_settings`) say, over real HTTP to a local server; a server that errors or hangs costs a
step at most its timeout and is counted in `info`, where the learner looks."""

from __future__ import annotations

import time

import numpy as np
import pytest

from tests.models.fake_openai import SERVER_ERROR, FakeOpenAI, ok
from tests.paths import SHARED_TASKS

pytestmark = [pytest.mark.needs_env, pytest.mark.usefixtures("quiet")]

TASKS = str(SHARED_TASKS)
REAL = "A_D1__FloorPlan1__seed0"  # agents agent_1, agent_2
PARTNER = "openai/fake-model"


@pytest.fixture(scope="module")
def server():
    with FakeOpenAI() as fake:
        yield fake


def seat_env(**options):
    from cocobench_agents.envs import SeatEnv

    return SeatEnv(TASKS, condition="D0_blind", seat="agent_2", partner=PARTNER,
                   task_id=REAL, max_steps=3, **options)


def play_out(environment) -> tuple[list[dict], dict]:
    """Step DONE until the end: every step's info, and the last."""
    infos, done = [], False
    environment.reset(seed=0)
    while not done:
        _, _, terminated, truncated, info = environment.step(-1)
        infos.append(info)
        done = terminated or truncated
    return infos, infos[-1]


def test_the_partner_is_called_where_the_run_variables_point(server, monkeypatch):
    server.program(default=ok("REASON: look\nACTION: 0"))
    monkeypatch.setenv("COCOBENCH_RUN_API_BASE", server.base_url)
    monkeypatch.setenv("COCOBENCH_RUN_TEMPERATURE", "0.25")
    environment = seat_env()
    _, last = play_out(environment)
    environment.close()
    assert server.count >= 1
    assert {r["model"] for r in server.requests} == {"fake-model"}
    assert {r["temperature"] for r in server.requests} == {0.25}
    assert last["backend_errors"] == 0 and last["models"] == {"agent_1": PARTNER,
                                                              "agent_2": "env"}
    decisions = [i["policy_decision"] for i in environment.team.episode.episode.items
                 if i.get("policy_decision", {}).get("agent") == "agent_1"]
    assert decisions and {d["model"] for d in decisions} == {PARTNER}


def test_model_settings_given_outrank_the_variables(server, monkeypatch):
    server.program(default=ok("REASON: look\nACTION: 0"))
    monkeypatch.setenv("COCOBENCH_RUN_API_BASE", "http://127.0.0.1:9/v1")  # nothing there
    environment = seat_env(model_settings={"api_base": server.base_url, "max_tokens": 7})
    play_out(environment)
    environment.close()
    assert server.count >= 1 and {r["max_tokens"] for r in server.requests} == {7}


def test_a_partner_server_that_fails_is_counted_where_the_learner_looks(server):
    from cocobench_agents.runfolder import is_infra_failure, unanswered_calls

    server.program(default=SERVER_ERROR)
    environment = seat_env(model_settings={"api_base": server.base_url, "max_retries": 1,
                                           "backoff_s": 0})
    observation, _ = environment.reset(seed=0)
    first = int(np.flatnonzero(observation["action_mask"])[1]) - 1  # [0] is DONE
    # agent_1's call (and its retry) failed as the round began, as in `cocobench run`
    assert server.count == 2
    *_, info = environment.step(first)  # agent_2 acts: the round lands; the next one begins
    assert server.count == 4 and info["unanswered_calls"] == 1
    *_, last = environment.step(-1)  # agent_2 is done: the episode ends
    environment.close()
    assert server.count == 4
    # The result line: an infrastructure failure, as the harness counts it.
    assert unanswered_calls(last) == 2 and is_infra_failure(last)


def test_a_partner_server_that_hangs_costs_a_step_its_timeout(server):
    server.program(default=ok(delay_s=30))
    environment = seat_env(model_settings={"api_base": server.base_url, "timeout_s": 0.5,
                                           "max_retries": 0})
    environment.reset(seed=0)
    started = time.monotonic()
    *_, info = environment.step(-1)
    took = time.monotonic() - started
    environment.close()
    assert took < 10, f"a step with a hung partner took {took:.1f} s (timeout 0.5 s)"
    assert info.get("unanswered_calls", info.get("usage", {}).get("backend_errors")) == 1


def test_bad_model_settings_are_named(monkeypatch):
    from cocobench_agents.envs import EnvError

    with pytest.raises(EnvError, match=r"model_settings\.timeout_s: Input should be greater"):
        seat_env(model_settings={"timeout_s": 0})
    with pytest.raises(EnvError, match=r"model_settings\.retries: Extra inputs"):
        seat_env(model_settings={"retries": 3})
    monkeypatch.setenv("COCOBENCH_RUN_API_BASE", "http://user:hunter2@127.0.0.1:9/v1")
    monkeypatch.setenv("COCOBENCH_RUN_MAX_RETRIES", "many")
    with pytest.raises(EnvError, match="COCOBENCH_RUN_MAX_RETRIES: Input should be a valid "
                                       "integer") as caught:
        seat_env()
    assert "hunter2" not in str(caught.value)

