"""What only the ``http`` transport does: model names it accepts, keys it needs, bodies it
cannot read, and connections it must close whoever forgets to."""

from __future__ import annotations

import asyncio
import gc
import logging
import warnings

import pytest

from cocobench_agents.models import (
    ModelConfigError,
    ModelError,
    ModelPool,
    ModelRequest,
    ModelSettings,
    OpenAIHTTPClient,
)

from .conftest import fast_settings
from .fake_openai import Behaviour, ok


def http_client(fake, **overrides) -> OpenAIHTTPClient:
    return OpenAIHTTPClient("openai/fake-model", fast_settings(fake, transport="http",
                                                              **overrides))


def test_a_body_that_is_not_a_completion_is_retried_then_transient(fake, fake_key):
    fake.program(default=Behaviour(200, raw=b"<html>502 Bad Gateway</html>"))
    with pytest.raises(ModelError) as info:
        asyncio.run(http_client(fake).complete(ModelRequest("p")))
    assert info.value.kind == "transient"
    assert fake.count == 3  # 1 + max_retries
    assert "not a chat completion" in info.value.message


def test_a_body_nested_too_deep_to_read_is_a_malformed_completion(fake, fake_key):
    # orjson refuses it (its depth limit); the standard library's reading, tried for a lone
    # surrogate's escape, then raised a RecursionError: an "other" error, not retried.
    fake.program(default=Behaviour(200, raw=b"[" * 100_000 + b"]" * 100_000))
    with pytest.raises(ModelError) as info:
        asyncio.run(http_client(fake).complete(ModelRequest("p")))
    assert info.value.kind == "transient"
    assert fake.count == 3  # 1 + max_retries
    assert "not a chat completion" in info.value.message


def test_the_pool_makes_http_clients_when_asked(fake, fake_key):
    pool = ModelPool(fast_settings(fake, transport="http"))
    client = pool.client("openai/fake-model", episode="e", agent=None)
    assert isinstance(client, OpenAIHTTPClient)
    assert client.url == f"{fake.base_url}/chat/completions"


def test_only_openai_model_names_are_accepted():
    pool = ModelPool(ModelSettings(transport="http", api_base="http://127.0.0.1:8000/v1"))
    pool.validate("openai/my-model")
    with pytest.raises(ModelConfigError, match="openai/NAME"):
        pool.validate("anthropic/claude-sonnet-4-5")


def test_a_remote_endpoint_needs_a_key(monkeypatch):
    monkeypatch.delenv("OPENAI_API_KEY", raising=False)
    pool = ModelPool(ModelSettings(transport="http"))
    with pytest.raises(ModelConfigError, match="OPENAI_API_KEY"):
        pool.validate("openai/gpt-4o")
    monkeypatch.setenv("OPENAI_API_KEY", "sk-from-the-environment")
    pool.validate("openai/gpt-4o")


def test_the_openai_key_variable_is_used_when_no_other_is_named(fake, monkeypatch):
    monkeypatch.setenv("OPENAI_API_KEY", "sk-from-the-environment")
    remote = OpenAIHTTPClient("openai/gpt-4o", ModelSettings(transport="http"))
    assert remote.url == "https://api.openai.com/v1/chat/completions"
    assert remote._headers["Authorization"] == "Bearer sk-from-the-environment"
    local = OpenAIHTTPClient("openai/m", ModelSettings(transport="http", api_base=fake.base_url))
    assert local._headers["Authorization"] == "Bearer no-key-required"  # never the real key


def test_connections_are_closed_without_aclose(fake, fake_key, caplog):
    fake.program(default=ok())
    client = http_client(fake)
    gc.collect()  # earlier tests' garbage (an anyio stream of Inspect's) warns on its own
    with warnings.catch_warnings(record=True) as caught, caplog.at_level(logging.ERROR):
        warnings.simplefilter("always")
        for _ in range(3):  # one event loop each, as a script calling asyncio.run per episode
            asyncio.run(client.complete(ModelRequest("p")))
        del client
        gc.collect()
    unclosed = [str(w.message) for w in caught if "Unclosed" in str(w.message)]
    assert unclosed == [] and "Unclosed" not in caplog.text


def test_aclose_closes_the_session(fake, fake_key):
    client = http_client(fake)

    async def call_then_close():
        await client.complete(ModelRequest("p"))
        session = client._session
        await client.aclose()
        return session

    assert asyncio.run(call_then_close()).closed
