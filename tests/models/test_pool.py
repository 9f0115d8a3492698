"""`ModelPool`: which client a spec gets, and the checks before a run starts."""

from __future__ import annotations

import pytest

from cocobench_agents.models import (
    BUILTIN_MODELS,
    GreedyClient,
    LiteLLMClient,
    ModelConfigError,
    ModelPool,
    ModelSettings,
    RandomClient,
    ReplayClient,
    ScriptedClient,
    is_builtin,
)


def test_builtin_names():
    assert BUILTIN_MODELS == ("greedy", "random", "scripted", "replay", "human")
    assert is_builtin("random:3") and is_builtin("scripted:x.json") and is_builtin("greedy")
    assert is_builtin("human")
    assert not is_builtin("openai/gpt-4o") and not is_builtin("ollama/llama3:8b")


def test_litellm_clients_are_shared_per_model_string():
    pool = ModelPool(ModelSettings(max_concurrency=3))
    a = pool.client("openai/gpt-4o", episode="e1", agent="agent_1")
    b = pool.client("openai/gpt-4o", episode="e2", agent=None)
    c = pool.client("anthropic/claude-sonnet-4-5", episode="e1", agent="agent_1")
    assert isinstance(a, LiteLLMClient) and a is b and a is not c
    assert a.name == "openai/gpt-4o" and a.settings.max_concurrency == 3


def test_builtins_are_made_per_episode_and_agent(tmp_path):
    script = tmp_path / "s.json"
    script.write_text('["ACTION: 1"]')
    replay = tmp_path / "trajectory.json"
    replay.write_text('{"task_id": "T", "planner_decisions": []}')
    pool = ModelPool()
    for spec, cls in [
        ("greedy", GreedyClient),
        ("random:4", RandomClient),
        (f"scripted:{script}", ScriptedClient),
        (f"replay:{replay}", ReplayClient),
    ]:
        first = pool.client(spec, episode="e1", agent="agent_1")
        assert isinstance(first, cls) and first.name == spec
        assert pool.client(spec, episode="e1", agent="agent_1") is first  # state kept
        assert pool.client(spec, episode="e1", agent="agent_2") is not first
        assert pool.client(spec, episode="e2", agent="agent_1") is not first
    pool.release("e1")
    assert pool.client("greedy", episode="e1", agent="agent_1") is not first


def test_cache_is_shared_by_the_pool(tmp_path):
    pool = ModelPool(ModelSettings(cache_dir=tmp_path))
    a = pool.client("openai/a", episode="e", agent=None)
    b = pool.client("openai/b", episode="e", agent=None)
    assert a.cache is b.cache is pool.cache and pool.cache.directory == tmp_path


@pytest.mark.parametrize(
    ("spec", "fragment"),
    [
        ("greedy:3", "takes no argument"),
        ("random:abc", "integer"),
        ("scripted", "needs a path"),
        ("replay:", "needs a path"),
    ],
)
def test_bad_builtin_specs(spec, fragment):
    with pytest.raises(ModelConfigError, match=fragment):
        ModelPool().validate(spec)


def test_good_builtin_specs_validate():
    for spec in ("greedy", "random", "random:12"):
        ModelPool().validate(spec)


def test_unknown_model_is_named_with_what_to_do():
    with pytest.raises(ModelConfigError) as info:
        ModelPool().validate("definitely-not-a-model-xyz")
    message = str(info.value)
    assert message.startswith("definitely-not-a-model-xyz: unknown model")
    assert "provider/model" in message and "\n" not in message


def test_missing_provider_key_names_the_variable(monkeypatch):
    monkeypatch.delenv("OPENAI_API_KEY", raising=False)
    monkeypatch.delenv("ANTHROPIC_API_KEY", raising=False)
    with pytest.raises(ModelConfigError, match="set OPENAI_API_KEY"):
        ModelPool().validate("openai/gpt-4o-mini")
    with pytest.raises(ModelConfigError, match="set ANTHROPIC_API_KEY"):
        ModelPool().validate("anthropic/claude-sonnet-4-5")
    monkeypatch.setenv("OPENAI_API_KEY", "sk-present-1234")
    ModelPool().validate("openai/gpt-4o-mini")


def test_api_key_env_must_be_set_when_named(monkeypatch):
    monkeypatch.delenv("MY_PROVIDER_API_KEY", raising=False)
    pool = ModelPool(ModelSettings(api_key_env="MY_PROVIDER_API_KEY"))
    with pytest.raises(ModelConfigError, match=r"MY_PROVIDER_API_KEY .* is not set"):
        pool.validate("openai/gpt-4o-mini")
    monkeypatch.setenv("MY_PROVIDER_API_KEY", "sk-present-1234")
    monkeypatch.delenv("OPENAI_API_KEY", raising=False)
    pool.validate("openai/gpt-4o-mini")


@pytest.mark.parametrize(
    "base", ["http://127.0.0.1:8080/v1", "http://localhost:11434", "http://[::1]:8000/v1"]
)
def test_local_servers_need_no_key(monkeypatch, base):
    monkeypatch.delenv("OPENAI_API_KEY", raising=False)
    ModelPool(ModelSettings(api_base=base)).validate("openai/my-local-model")


def test_remote_base_still_needs_a_key(monkeypatch):
    monkeypatch.delenv("OPENAI_API_KEY", raising=False)
    with pytest.raises(ModelConfigError, match="OPENAI_API_KEY"):
        ModelPool(ModelSettings(api_base="https://api.example.com/v1")).validate("openai/m")
