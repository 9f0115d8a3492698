"""`ModelSettings`, the grammar builder and the message builder (pure functions)."""

from __future__ import annotations

import json

import pytest

from cocobench_agents.models import (
    LOCAL_PLACEHOLDER_KEY,
    MenuOption,
    ModelRequest,
    ModelSettings,
    build_messages,
    cap_reply,
    is_local_url,
    menu_grammar,
    wants_message,
)


def test_defaults_follow_the_reference():
    s = ModelSettings()
    assert s.timeout_s == 180 and s.max_retries == 2 and s.max_attempts == 3
    assert s.max_concurrency == 16 and s.temperature == "auto"
    assert s.cache_dir is None and s.seed is None and not s.grammar


def test_to_record_is_json_safe_and_complete(tmp_path):
    s = ModelSettings(
        api_base="http://127.0.0.1:1/v1", api_key_env="X_API_KEY", cache_dir=tmp_path,
        extra_params={"extra_body": {"top_k": 1}, "odd": object()},
    )  # fmt: skip
    record = json.loads(json.dumps(s.to_record()))
    assert record["cache_dir"] == str(tmp_path)
    assert record["api_key_env"] == "X_API_KEY"
    assert record["extra_params"]["extra_body"] == {"top_k": 1}
    assert set(record) >= {"timeout_s", "max_retries", "max_concurrency", "temperature", "seed"}


def test_extra_params_are_copied():
    params = {"top_p": 0.5}
    s = ModelSettings(extra_params=params)
    params["top_p"] = 0.9
    assert s.extra_params == {"top_p": 0.5}


@pytest.mark.parametrize(
    ("model", "expected"),
    [("gpt-4o", 0.0), ("openai/gpt-4o-mini", 0.0), ("openai/o3-mini", 0.0), ("o4-mini", 0.0),
     ("anthropic/claude-sonnet-4-5", None), ("openai/smollm2", None)],
)  # fmt: skip
def test_auto_temperature(model, expected):
    assert ModelSettings().temperature_for(model) == expected
    assert ModelSettings(temperature=None).temperature_for(model) is None
    assert ModelSettings(temperature=0.4).temperature_for(model) == 0.4


@pytest.mark.parametrize(
    "bad",
    [{"timeout_s": 0}, {"max_retries": -1}, {"max_concurrency": 0}, {"temperature": "hot"},
     {"api_key_env": "sk-live-abc123"}, {"max_reply_chars": 0}],
)  # fmt: skip
def test_invalid_settings(bad):
    with pytest.raises(ValueError):
        ModelSettings(**bad)


def test_local_urls_and_placeholder_key(monkeypatch):
    assert is_local_url("http://127.0.0.1:8080/v1") and is_local_url("http://localhost")
    assert is_local_url("http://[::1]:1/v1") and is_local_url("0.0.0.0:8000")
    assert not is_local_url("https://api.openai.com/v1") and not is_local_url(None)
    assert not is_local_url("http://10.0.0.5:8000/v1")
    assert ModelSettings(api_base="http://127.0.0.1:1/v1").call_key() == LOCAL_PLACEHOLDER_KEY
    assert ModelSettings().call_key() is None
    monkeypatch.setenv("MY_KEY_VAR", "abcdef")
    assert ModelSettings(api_base="http://127.0.0.1:1", api_key_env="MY_KEY_VAR").call_key() == (
        "abcdef"
    )


def test_grammar_lists_menu_ids_and_done():
    menu = (MenuOption(1, "Wait", "W"), MenuOption(12, "Find", "F"), MenuOption(1, "Wait", "W"))
    grammar = menu_grammar(menu)
    assert grammar.startswith('root ::= "REASON: " reason "\\nACTION: " action\n')
    assert 'action ::= "12" | "1" | "DONE"' in grammar
    assert "msg" not in grammar
    assert 'action ::= "DONE"' in menu_grammar(())
    with_msg = menu_grammar(menu, with_msg=True)
    assert "action msg?" in with_msg and 'msg ::= "\\nMSG: "' in with_msg
    assert wants_message("...end with a line MSG: <text>") and not wants_message("no message")


def test_messages_text_and_image_mode():
    assert build_messages(ModelRequest("hi")) == [{"role": "user", "content": "hi"}]
    (msg,) = build_messages(ModelRequest("hi", images=(b"a", b"b")))
    assert [p["type"] for p in msg["content"]] == ["text", "image_url", "image_url"]


def test_cap_reply_cuts_without_adding_text():
    assert cap_reply("short", 10) == ("short", 0)
    assert cap_reply("x" * 10, 10) == ("x" * 10, 0)
    assert cap_reply("x" * 50, 10) == ("x" * 10, 40)


def test_the_run_variables_are_the_ones_cocobench_run_reads():
    from cocobench_agents.cli.run_cmd import run_command
    from cocobench_agents.setting_kinds import flag_of, run_variable

    read = {p.envvar for p in run_command.params}
    named = {run_variable(flag) for info in ModelSettings.model_fields.values()
             if (flag := flag_of(info)) is not None}
    assert len(named) >= 10 and named <= read, sorted(named - read)


def test_settings_from_the_run_variables():
    environ = {"COCOBENCH_RUN_API_BASE": "http://127.0.0.1:8080/v1", "COCOBENCH_RUN_TIMEOUT": "2.5",
               "COCOBENCH_RUN_GRAMMAR": "1", "COCOBENCH_RUN_EXTRA": '{"top_p": 0.5}',
               "COCOBENCH_RUN_SEED": "", "OTHER": "x"}
    settings = ModelSettings.from_run_variables(environ)
    assert (settings.api_base, settings.timeout_s, settings.grammar, settings.extra_params,
            settings.seed) == ("http://127.0.0.1:8080/v1", 2.5, True, {"top_p": 0.5}, None)
    assert ModelSettings.from_run_variables({}) == ModelSettings()
    with pytest.raises(ValueError, match="COCOBENCH_RUN_TIMEOUT: Input should be greater than 0"):
        ModelSettings.from_run_variables({"COCOBENCH_RUN_TIMEOUT": "-1"})


@pytest.mark.parametrize(("variable", "value"), [
    ("COCOBENCH_RUN_TEMPERATURE", "nan"), ("COCOBENCH_RUN_TEMPERATURE", "-inf"),
    ("COCOBENCH_RUN_TIMEOUT", "inf"), ("COCOBENCH_RUN_EXTRA", '{"top_p": NaN}'),
    ("COCOBENCH_RUN_EXTRA", '{"x": {"y": [Infinity]}}'), ("COCOBENCH_RUN_EXTRA", "[" * 10_000),
], ids=["nan", "-inf", "timeout-inf", "extra-NaN", "extra-Infinity", "extra-deep"])  # fmt: skip
def test_a_number_that_is_not_finite_is_refused_naming_its_variable(variable, value):
    # `nan` was accepted, and every call then failed later as a "transient" error.
    with pytest.raises(ValueError, match=f"^{variable}: ") as info:
        ModelSettings.from_run_variables({variable: value})
    assert "\n" not in str(info.value)
    with pytest.raises(ValueError, match="finite"):
        ModelSettings(temperature=float("nan"))
    with pytest.raises(ValueError, match="not finite"):
        ModelSettings(extra_params={"top_p": float("inf")})
