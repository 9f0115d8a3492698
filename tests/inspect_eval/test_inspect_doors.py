"""One meaning at both doors, against one OpenAI-compatible server on 127.0.0.1: every key of
`-T extra` reaches the server as `cocobench run --extra` sends it (``top_k`` too, which
Inspect's OpenAI providers would drop); a decision's prompt tokens count the provider's
cached prefix at both doors (Inspect counts it apart); its cost is priced alike; a reply of
either door's cache is billed alike; an unsent temperature is warned of and a misspelt seat
refused at both."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from cocobench_agents.models.openai_http import token_prices
from tests.faults.test_model_faults import Provider
from tests.models.fake_openai import Behaviour, completion_body

from .conftest import config_paths, openai_api, subprocess_env

pytestmark = [pytest.mark.needs_inspect, pytest.mark.slow]

EXTRA = {"top_k": 20, "top_p": 0.9, "min_p": 0.05, "repeat_penalty": 1.1,
         "stop": ["\n\nQ:"]}
#: Keys of a request body that say what was asked, not how it was sampled.
ASKED = {"messages", "model", "stream", "stream_options", "n", "max_tokens", "temperature",
         "seed", "tools", "tool_choice"}
PROMPT, CACHED, COMPLETION = 900, 600, 4
MODEL = "gpt-4o-mini"  # a model LiteLLM's cost map prices: the cost is counted at both doors
DONE = "REASON: nothing left to do\nACTION: DONE"


def cached_reply() -> Behaviour:
    """DONE, with usage of which most of the prompt came from the provider's cache."""
    body = completion_body(DONE, prompt_tokens=PROMPT, completion_tokens=COMPLETION)
    body["usage"]["prompt_tokens_details"] = {"cached_tokens": CACHED}
    return Behaviour(200, body)


@pytest.fixture
def provider():
    with Provider() as server:
        server.program(default=cached_reply())
        yield server


def _decisions(server: Provider) -> list[dict[str, Any]]:
    """The bodies of the decisions' requests (not the pre-flight's connection check)."""
    return [body for body in server.requests
            if "connection check" not in json.dumps(body["messages"])]


def _sampling(body: dict[str, Any]) -> dict[str, Any]:
    return {k: v for k, v in body.items() if k not in ASKED}


def _our_door(task: str, provider: Provider, out: Path, cache: Path
              ) -> list[dict[str, Any]]:
    """The decisions of `cocobench run` (http transport, --extra, --cache) of a C0_blind
    episode of `task` against `provider`."""
    done = subprocess.run(
        [sys.executable, "-m", "cocobench_agents.cli", "run", "--task", task, "--model",
         f"openai/{MODEL}", "--conditions", "C0_blind", "--max-steps", "2", "--transport",
         "http", "--api-base", provider.base_url, "--api-key-env", "FAKE_API_KEY",
         "--extra", json.dumps(EXTRA), "--temperature", "0", "--cache", str(cache),
         "--out", str(out)],
        capture_output=True, text=True, check=False, timeout=300,
        env={**subprocess_env(), "FAKE_API_KEY": "sk-fake-doors-0001"})
    assert done.returncode == 0, done.stderr[-3000:]
    [line] = [json.loads(x) for x in (out / "results.jsonl").read_text().splitlines()]
    return json.loads((out / line["trajectory"]).read_text())["planner_decisions"]


def _inspect_door(task: str, model: str, logs: Path) -> list[dict[str, Any]]:
    """The decisions of `inspect eval` (-T extra, --cache) of the same episode."""
    from inspect_ai import eval as inspect_eval
    from inspect_ai.log import read_eval_log

    from cocobench_agents.inspect_eval.solver import TRAJECTORY
    from cocobench_agents.inspect_eval.task import cocobench

    [log] = inspect_eval(cocobench, task_args={"task": task, "conditions": "C0_blind",
                                               "max_steps": 2, "extra": EXTRA,
                                               "temperature": 0},
                         model=model, log_dir=str(logs), display="none", cache=True)
    [sample] = read_eval_log(log.location).samples
    assert sample.error is None, sample.error
    return sample.store[TRAJECTORY]["planner_decisions"]


def _billing(decisions: list[dict[str, Any]]) -> list[tuple[Any, ...]]:
    """What each decision was billed and what a cached one saved (its latency aside)."""
    return [(d["cached"], d["prompt_tokens"], d["completion_tokens"], d["cost_usd"],
             d.get("saved") and {k: v for k, v in d["saved"].items() if k != "latency_s"})
            for d in decisions]


def test_extra_tokens_cost_and_cached_replies_mean_the_same_at_both_doors(
        tmp_path: Path, provider: Provider, monkeypatch):
    """The same episode at both doors, each run twice with its cache (ours ``--cache``,
    Inspect's ``--cache``): the same request bodies, and every decision billed alike:
    tokens (the provider's cached prefix counted in the prompt), cost from LiteLLM's cost
    map, and, run again, the cache's replies billed 0 with what they cost kept as saved."""
    task = config_paths()[0]
    monkeypatch.setenv("INSPECT_CACHE_DIR", str(tmp_path / "inspect-cache"))
    model = f"{openai_api(monkeypatch, provider.base_url)}/{MODEL}"
    ours = _our_door(task, provider, tmp_path / "run", tmp_path / "cache")
    our_bodies = _decisions(provider)
    provider.program(default=cached_reply())
    theirs = _inspect_door(task, model, tmp_path / "logs")
    their_bodies = _decisions(provider)

    # every key of --extra / -T extra reached the server, with the same value
    assert our_bodies and len(our_bodies) == len(their_bodies) == len(ours) == len(theirs)
    for a, b in zip(our_bodies, their_bodies):
        assert _sampling(a) == _sampling(b) == EXTRA, (a, b)
    # tokens (the cached prefix in the prompt's) and cost, decision by decision
    price_in, price_out = token_prices(f"openai/{MODEL}")
    cost = PROMPT * price_in + COMPLETION * price_out
    assert cost > 0
    assert _billing(ours) == _billing(theirs) == \
        [(False, PROMPT, COMPLETION, pytest.approx(cost), None)] * len(ours)

    # again, each from its own cache: nothing reaches the server, billed 0, cost saved
    provider.program()
    ours = _our_door(task, provider, tmp_path / "again", tmp_path / "cache")
    theirs = _inspect_door(task, model, tmp_path / "logs")
    assert not _decisions(provider)
    saved = {"prompt_tokens": PROMPT, "completion_tokens": COMPLETION,
             "cost_usd": pytest.approx(cost)}
    assert _billing(ours) == _billing(theirs) == [(True, 0, 0, 0, saved)] * len(ours)


def test_a_misspelt_seat_is_refused_at_both_doors(tmp_path: Path):
    from inspect_ai import eval as inspect_eval

    from cocobench_agents.inspect_eval.params import TaskParameterError
    from cocobench_agents.inspect_eval.task import cocobench

    task = config_paths()[0]  # agents agent_1 and agent_2
    with pytest.raises(TaskParameterError) as refused:
        inspect_eval(cocobench, task_args={"task": task, "conditions": "D1_blind"},
                     model="mockllm/model", model_roles={"agnet_2": "mockllm/model"},
                     log_dir=str(tmp_path / "logs"), display="none")
    assert str(refused.value) == ("--model-role agnet_2: no agent of the selected instances "
                                  "is named so (their agents: agent_1, agent_2)")
    assert not (tmp_path / "logs").exists() or not list((tmp_path / "logs").iterdir())
    done = subprocess.run(
        [sys.executable, "-m", "cocobench_agents.cli", "run", "--task", task, "--model",
         "greedy", "--agent-model", "agnet_2=random", "--conditions", "D1_blind",
         "--out", str(tmp_path / "run")],
        capture_output=True, text=True, check=False, timeout=300, env=subprocess_env())
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert "--agent-model agnet_2: no agent of the selected instances is named so (their " \
           "agents: agent_1, agent_2)" in done.stderr
    assert not (tmp_path / "run").exists()


def test_an_unsent_temperature_is_warned_at_both_doors(tmp_path: Path, provider: Provider,
                                                        monkeypatch, caplog):
    from inspect_ai import eval as inspect_eval

    from cocobench_agents.inspect_eval.task import cocobench

    model = f"{openai_api(monkeypatch, provider.base_url)}/healthy"
    args = {"task": config_paths()[0], "conditions": "C0_blind", "max_steps": 1}
    said = {}
    for temperature in (None, 0):
        caplog.clear()
        inspect_eval(cocobench, task_args={**args, "temperature": temperature},
                     model=model, log_dir=str(tmp_path / "logs"),
                     display="none")
        said[temperature] = caplog.text
    assert f"sampling is unset for {model}" in said[None], said
    assert "not reproducible; -T temperature=0 fixes it" in said[None]
    assert "sampling is unset" not in said[0]
    done = subprocess.run(
        [sys.executable, "-m", "cocobench_agents.cli", "run", "--task", config_paths()[0],
         "--model", "openai/healthy", "--conditions", "C0_blind", "--max-steps", "1",
         "--api-base", provider.base_url, "--api-key-env", "FAKE_API_KEY",
         "--out", str(tmp_path / "run")],
        capture_output=True, text=True, check=False, timeout=300,
        env={**subprocess_env(), "FAKE_API_KEY": "sk-fake-doors-0001"})
    assert done.returncode == 0, done.stderr[-2000:]
    assert "sampling is unset for openai/healthy" in done.stdout + done.stderr


def test_a_samples_id_is_stable_when_arms_are_added():
    from cocobench_agents.inspect_eval.task import cocobench

    def ids(prompt_suite: str) -> set[str]:
        task = cocobench(task=config_paths()[0], conditions="C0_blind",
                         prompt_suite=prompt_suite)
        return {str(sample.id) for sample in task.dataset}

    alone, variant = ids("cocobench-v1"), ids("cocobench-v1+no-hint")
    both = ids("cocobench-v1,cocobench-v1+no-hint")
    assert alone == {"C0_blind/A_D1__FloorPlan1__seed0"}
    assert variant == {"C0_blind/cocobench-v1+no-hint/A_D1__FloorPlan1__seed0"}
    assert both == alone | variant  # adding an arm kept every id
