"""No API key in any message, error, record or cache file we produce."""

from __future__ import annotations

import asyncio
import json

import pytest

from cocobench_agents.models import (
    REDACTED,
    ModelConfigError,
    ModelError,
    ModelPool,
    ModelRequest,
    ModelSettings,
    redact,
    redact_obj,
)

from .conftest import FAKE_KEY, FAKE_KEY_ENV, fast_settings
from .fake_openai import SERVER_ERROR, Behaviour, error, ok


def test_redact_scrubs_secret_named_variables(monkeypatch):
    monkeypatch.setenv("SOME_API_KEY", "key-value-123")
    monkeypatch.setenv("HF_TOKEN", "hf_abcdefgh")
    monkeypatch.setenv("APP_SECRET", "s3cr3t-value")
    monkeypatch.setenv("PLAIN_SETTING", "visible-value")
    text = "key-value-123 hf_abcdefgh s3cr3t-value visible-value"
    assert redact(text) == f"{REDACTED} {REDACTED} {REDACTED} visible-value"
    assert redact("my custom-key-999", ["custom-key-999"]) == f"my {REDACTED}"
    assert redact_obj({"k": ["key-value-123", 3]}) == {"k": [REDACTED, 3]}


def test_short_values_are_left_alone(monkeypatch):
    monkeypatch.setenv("DEBUG_TOKEN", "1")
    assert redact("step 1 of 10") == "step 1 of 10"


def test_key_echoed_by_the_server_never_leaks(fake, make_client, fake_key):
    # The server puts the Authorization header (hence the key) in its error message.
    fake.program(default=Behaviour(401, echo_auth=True))
    with pytest.raises(ModelError) as info:
        asyncio.run(make_client().complete(ModelRequest("x")))
    err = info.value
    assert fake.headers[0]["authorization"] == f"Bearer {FAKE_KEY}"  # the key was used
    assert FAKE_KEY not in str(err) and FAKE_KEY not in err.message
    assert FAKE_KEY not in repr(err) and FAKE_KEY not in json.dumps(err.extra)
    assert REDACTED in err.message


@pytest.mark.parametrize("behaviour", [SERVER_ERROR, error(400, f"bad key {FAKE_KEY}")])
def test_no_key_in_any_error(fake, make_client, fake_key, behaviour):
    fake.program(default=behaviour)
    with pytest.raises(ModelError) as info:
        asyncio.run(make_client(max_retries=1).complete(ModelRequest("x")))
    assert FAKE_KEY not in repr(info.value)


def test_no_key_in_records_or_cache_files(fake, fake_key, tmp_path):
    # A user may pass the key in custom headers by hand: it must not reach the record either.
    headers = {"X-Api-Key": FAKE_KEY}
    settings = fast_settings(fake, cache_dir=tmp_path, extra_params={"extra_headers": headers})
    record = settings.to_record()
    text = json.dumps(record)  # JSON-safe
    assert FAKE_KEY not in text
    assert record["api_key_env"] == FAKE_KEY_ENV
    fake.program(ok(f"REASON: I was told {FAKE_KEY[:4]}\nACTION: 1"))
    pool = ModelPool(settings)
    client = pool.client("openai/fake-model", episode="e", agent=None)
    asyncio.run(client.complete(ModelRequest("x")))
    assert fake.headers[0]["x-api-key"] == FAKE_KEY
    for file in tmp_path.rglob("*"):
        if file.is_file():
            assert FAKE_KEY not in file.read_text()


def test_config_errors_never_show_the_key(monkeypatch, tmp_path):
    monkeypatch.setenv(FAKE_KEY_ENV, FAKE_KEY)
    with pytest.raises(ModelConfigError) as info:
        ModelPool().validate(f"scripted:{tmp_path / FAKE_KEY}")
    assert FAKE_KEY not in str(info.value)


def test_settings_repr_has_no_key(fake_key):
    settings = ModelSettings(api_key_env=FAKE_KEY_ENV)
    assert FAKE_KEY not in repr(settings)
    assert settings.api_key() == FAKE_KEY
