"""`cocobench run --print-config` never prints a secret, wherever it was given: a flag, a
``COCOBENCH_RUN_*`` variable or the --config file (an ``--extra`` key or header, the
``user:password@`` of ``--api-base``), nor the key an ``--api-key-env`` variable holds."""

from __future__ import annotations

import json

import pytest
import yaml

from cocobench_agents.cli import main
from cocobench_agents.models.secrets import REDACTED, basic_token

RUN = ["run", "--suite", "demo", "--model", "openai/gpt-4o"]
KEY, TOKEN, PASSWORD = "sk-extra-KEY-4711", "tok-BEARER-0815", "pw-URL-1312"
EXTRA = {"api_key": KEY, "headers": {"Authorization": f"Bearer {TOKEN}"}, "top_p": 0.9}
ENDPOINT = f"http://lab:{PASSWORD}@127.0.0.1:8080/v1"


def printed(capsys, tmp_path, *argv: str) -> tuple[str, str]:
    assert main([*RUN, *argv, "--out", str(tmp_path / "run"), "--print-config"]) == 0
    out, err = capsys.readouterr()
    for secret in (KEY, TOKEN, PASSWORD, basic_token("lab", PASSWORD)):
        assert secret not in out and secret not in err
    return out, err


def assert_redacted(config: dict) -> None:
    settings = config["model_settings"]
    assert settings["extra_params"] == {"api_key": REDACTED,
                                        "headers": {"Authorization": REDACTED}, "top_p": 0.9}
    assert settings["api_base"] == f"http://{REDACTED}@127.0.0.1:8080/v1"


def test_secrets_given_as_flags(capsys, tmp_path) -> None:
    out, err = printed(capsys, tmp_path, "--extra", json.dumps(EXTRA), "--api-base", ENDPOINT)
    assert_redacted(yaml.safe_load(out))
    assert err.count(REDACTED) == 1 and "give them again" in err  # a config to run with


def test_secrets_given_as_variables(capsys, tmp_path, monkeypatch) -> None:
    monkeypatch.setenv("COCOBENCH_RUN_EXTRA", json.dumps(EXTRA))
    monkeypatch.setenv("COCOBENCH_RUN_API_BASE", ENDPOINT)
    out, _ = printed(capsys, tmp_path)
    assert_redacted(yaml.safe_load(out))


@pytest.mark.parametrize("suffix", [".yaml", ".toml"])
def test_secrets_given_in_a_config_file(capsys, tmp_path, suffix) -> None:
    config = tmp_path / f"lab{suffix}"
    if suffix == ".yaml":
        config.write_text(yaml.safe_dump({"model_settings": {"extra_params": EXTRA,
                                                             "api_base": ENDPOINT}}))
    else:
        config.write_text(f'[model_settings]\napi_base = "{ENDPOINT}"\n'
                          f'[model_settings.extra_params]\napi_key = "{KEY}"\ntop_p = 0.9\n'
                          f'[model_settings.extra_params.headers]\n'
                          f'Authorization = "Bearer {TOKEN}"\n')
    out, _ = printed(capsys, tmp_path, "--config", str(config))
    assert_redacted(yaml.safe_load(out))


def test_the_key_an_api_key_env_variable_holds_is_never_printed(capsys, tmp_path,
                                                                monkeypatch) -> None:
    monkeypatch.setenv("LAB_KEY_FOR_PRINT_CONFIG", KEY)
    out, _ = printed(capsys, tmp_path, "--api-key-env", "LAB_KEY_FOR_PRINT_CONFIG",
                       "--extra", f'{{"note": "{KEY}"}}')  # the key pasted where no name says
    config = yaml.safe_load(out)
    assert config["model_settings"]["api_key_env"] == "LAB_KEY_FOR_PRINT_CONFIG"
    assert config["model_settings"]["extra_params"] == {"note": REDACTED}


def test_a_config_without_secrets_prints_as_given_and_says_nothing(capsys, tmp_path) -> None:
    out, err = printed(capsys, tmp_path, "--extra", '{"top_p": 0.9}', "--api-base",
                       "http://127.0.0.1:8080/v1")
    settings = yaml.safe_load(out)["model_settings"]
    assert settings["extra_params"] == {"top_p": 0.9}
    assert settings["api_base"] == "http://127.0.0.1:8080/v1"
    assert REDACTED not in out and err == ""
