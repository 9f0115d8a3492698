"""A real local model through Inspect's OpenAI-compatible provider (``openai-api``) against
the llama.cpp server of the `llm` tests: the episode completes, each decision is a model
event of the log, and Inspect's token counts are ours."""

from __future__ import annotations

import pytest

from tests.models.llama_server import llama_server  # noqa: F401 - the fixture

pytestmark = [pytest.mark.needs_inspect, pytest.mark.llm]


def test_a_real_model_plays_an_episode_through_inspect(llama_server, tmp_path,  # noqa: F811
                                                        monkeypatch):
    from inspect_ai import eval as inspect_eval
    from inspect_ai.log import read_eval_log

    from cocobench_agents.inspect_eval.solver import RESULT, TRAJECTORY
    from cocobench_agents.inspect_eval.task import cocobench

    monkeypatch.setenv("LLAMACPP_BASE_URL", llama_server.base_url)
    monkeypatch.setenv("LLAMACPP_API_KEY", "no-key-required")
    [log] = inspect_eval(
        cocobench(task="demo", task_id="G_D1__DemoLivingRoom1__seed0", conditions="C0_blind",
                  max_steps=2, temperature=0, max_tokens=48),
        model=f"openai-api/llamacpp/{llama_server.model}", log_dir=str(tmp_path),
        display="none", max_retries=1)
    log = read_eval_log(log.location)
    assert log.status == "success", log.error
    [sample] = log.samples
    assert sample.error is None
    line = sample.store[RESULT]
    assert line["terminal_reason"] is not None and line["backend_errors"] == 0
    decisions = sample.store[TRAJECTORY]["planner_decisions"]
    events = [e for e in sample.events if e.event == "model"]
    assert decisions and len(events) == len(decisions)
    assert [e.output.completion for e in events] == [d["raw_output"] for d in decisions]
    # Inspect's token counts and ours agree: our prompt tokens count the prefix llama.cpp
    # served from its prompt cache, which Inspect counts apart
    [usage] = sample.model_usage.values()
    assert usage.input_tokens + (usage.input_tokens_cache_read or 0) + \
        (usage.input_tokens_cache_write or 0) == sum(d["prompt_tokens"] for d in decisions) > 0
    assert usage.output_tokens == sum(d["completion_tokens"] for d in decisions) > 0
    assert "success" in sample.scores["cocobench_scorer"].value
