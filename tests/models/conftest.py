"""Fixtures for the model tests: a scripted fake OpenAI server, a fake key, and the real
llama.cpp server (tests marked ``llm``). Nothing here reaches the internet."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from cocobench_agents.models import (
    ENDPOINT_TRANSPORTS,
    LiteLLMClient,
    ModelSettings,
    OpenAIHTTPClient,
    RemoteClient,
)

from .fake_openai import FakeOpenAI, ok
from .llama_server import llama_server  # noqa: F401 - a fixture, re-exported for this folder

FAKE_KEY_ENV = "FAKE_PROVIDER_API_KEY"
FAKE_KEY = "sk-test-should-not-leak"


@pytest.fixture(scope="session")
def fake_server() -> Iterator[FakeOpenAI]:
    """One fake OpenAI server for the session (tests reprogram it)."""
    with FakeOpenAI() as server:
        yield server


@pytest.fixture
def fake(fake_server: FakeOpenAI) -> FakeOpenAI:
    """The fake server, freshly programmed to answer every request with a plain success."""
    return fake_server.program(default=ok())


@pytest.fixture
def fake_key(monkeypatch: pytest.MonkeyPatch) -> str:
    """The fake provider key, set in the environment."""
    monkeypatch.setenv(FAKE_KEY_ENV, FAKE_KEY)
    return FAKE_KEY


def fast_settings(fake: FakeOpenAI, **overrides: object) -> ModelSettings:
    """Settings for the fake server with tiny backoffs, so retry tests take milliseconds."""
    values: dict[str, object] = {
        "api_base": fake.base_url,
        "api_key_env": FAKE_KEY_ENV,
        "timeout_s": 5.0,
        "max_retries": 2,
        "backoff_s": 0.001,
        "backoff_max_s": 0.005,
    }
    values.update(overrides)
    return ModelSettings(**values)  # type: ignore[arg-type]


CLIENTS: dict[str, type[RemoteClient]] = {"litellm": LiteLLMClient, "http": OpenAIHTTPClient}


@pytest.fixture(params=ENDPOINT_TRANSPORTS)
def transport(request: pytest.FixtureRequest) -> str:
    """Each transport in turn: the remote-client tests hold for both."""
    return request.param


@pytest.fixture
def make_client(fake: FakeOpenAI, fake_key: str, transport: str):
    """A factory: ``make_client(model="openai/fake-model", **settings)`` → the transport's
    `RemoteClient`."""

    def make(model: str = "openai/fake-model", **overrides: object) -> RemoteClient:
        settings = fast_settings(fake, transport=transport, **overrides)
        return CLIENTS[transport](model, settings)

    return make
