"""The provider and key checks made without importing LiteLLM agree with LiteLLM's own."""

from __future__ import annotations

import pytest

from cocobench_agents.models import import_litellm
from cocobench_agents.models.providers import KEY_VARIABLES, key_variables, known_provider


@pytest.mark.parametrize(("provider", "variables"), sorted(KEY_VARIABLES.items()))
def test_the_key_table_matches_litellm(provider, variables, monkeypatch):
    litellm = import_litellm()
    model = f"{provider}/some-model"
    for variable in variables:
        monkeypatch.delenv(variable, raising=False)
    assert set(litellm.validate_environment(model=model)["missing_keys"]) == set(variables)
    for variable in variables:  # any one of them is enough, for LiteLLM as for us
        monkeypatch.setenv(variable, "sk-test-123456")
        assert litellm.validate_environment(model=model)["missing_keys"] == []
        monkeypatch.delenv(variable)


def test_bare_names_take_their_provider_from_the_cost_map():
    assert known_provider("gpt-4o") == "openai"
    assert key_variables("gpt-4o") == ("OPENAI_API_KEY",)
    assert known_provider("anthropic/anything") == "anthropic"
    assert known_provider("gpt4o-typo") is None


def test_any_one_of_a_providers_key_variables_is_enough(monkeypatch):
    from cocobench_agents.models import ModelConfigError, ModelPool

    monkeypatch.delenv("GEMINI_API_KEY", raising=False)
    monkeypatch.delenv("GOOGLE_API_KEY", raising=False)
    with pytest.raises(ModelConfigError, match="GEMINI_API_KEY or GOOGLE_API_KEY"):
        ModelPool().validate("gemini/gemini-2.0-flash")
    monkeypatch.setenv("GOOGLE_API_KEY", "sk-test-123456")
    ModelPool().validate("gemini/gemini-2.0-flash")
