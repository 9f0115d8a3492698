"""The remote clients (LiteLLM and the ``http`` transport, each test for both) against a local
fake OpenAI server: retries, timeouts, error kinds, payloads."""

from __future__ import annotations

import asyncio
import base64
import time

import pytest

from cocobench_agents.models import (
    MenuOption,
    ModelError,
    ModelRequest,
)
from cocobench_agents.models.chat_schema import request_problem

from .fake_openai import (
    BAD_REQUEST,
    CONTEXT_WINDOW,
    RATE_LIMITED,
    SERVER_ERROR,
    Behaviour,
    error,
    ok,
)

REQUEST = ModelRequest(prompt="Pick an action.")


def ask(client, request: ModelRequest = REQUEST):
    return asyncio.run(client.complete(request))


def fails(client, request: ModelRequest = REQUEST) -> ModelError:
    with pytest.raises(ModelError) as info:
        ask(client, request)
    return info.value


# -- transient errors are retried ----------------------------------------------------------


def test_success_counts_tokens_and_has_no_retries(fake, make_client):
    reply = ask(make_client())
    assert reply.text == "REASON: fine\nACTION: 1"
    assert (reply.prompt_tokens, reply.completion_tokens) == (11, 7)
    assert reply.retries == 0 and not reply.cached
    assert reply.cost_usd == 0.0  # not in LiteLLM's cost map: free, not an error
    assert reply.latency_s > 0
    assert fake.count == 1


def test_rate_limit_then_success_is_retried(fake, make_client):
    fake.program(RATE_LIMITED, ok("REASON: r\nACTION: 4"))
    reply = ask(make_client())
    assert reply.text.endswith("ACTION: 4")
    assert reply.retries == 1
    assert fake.count == 2


def test_server_error_then_success_is_retried(fake, make_client):
    fake.program(SERVER_ERROR, ok())
    assert ask(make_client()).retries == 1
    assert fake.count == 2


@pytest.mark.parametrize("status", [502, 503, 504])
def test_other_5xx_are_retried(fake, make_client, status):
    fake.program(error(status, "upstream trouble"), ok())
    assert ask(make_client()).retries == 1
    assert fake.count == 2


def test_persistent_server_error_gives_transient_after_all_attempts(fake, make_client):
    fake.program(default=SERVER_ERROR)
    err = fails(make_client(max_retries=3))
    assert err.kind == "transient"
    assert err.retries == 3
    assert err.extra["attempts"] == 4 and err.extra["status_code"] == 500
    assert fake.count == 4  # max_retries + 1 attempts, no more


def test_persistent_rate_limit_gives_rate_limit(fake, make_client):
    fake.program(default=RATE_LIMITED)
    err = fails(make_client(max_retries=1))
    assert err.kind == "rate_limit"
    assert fake.count == 2


def test_retry_after_header_is_honoured(fake, make_client):
    limited = Behaviour(429, RATE_LIMITED.body, headers=(("Retry-After", "0.3"),))
    fake.program(limited, ok())
    start = time.perf_counter()
    reply = ask(make_client(backoff_max_s=2.0))
    assert reply.retries == 1
    assert time.perf_counter() - start >= 0.3


def test_too_slow_gives_timeout_after_retries(fake, make_client):
    # Attempt n gets timeout_s × n: 0.2 s, then 0.4 s; the server would need 10 s.
    fake.program(default=ok(delay_s=10.0))
    start = time.perf_counter()
    err = fails(make_client(timeout_s=0.2, max_retries=1))
    elapsed = time.perf_counter() - start
    assert err.kind == "timeout"
    assert err.retries == 1
    assert fake.count == 2
    assert 0.55 <= elapsed < 8.0  # both timeouts waited for, the server never


def test_slow_then_fast_succeeds(fake, make_client):
    fake.program(ok(delay_s=10.0), ok("REASON: late\nACTION: 2"))
    reply = ask(make_client(timeout_s=0.5))
    assert reply.retries == 1 and reply.text.endswith("ACTION: 2")


@pytest.mark.parametrize("content", ["", None, "  \n "])
def test_empty_completion_is_retried_then_fails_as_empty(fake, make_client, content):
    fake.program(default=ok(content))
    err = fails(make_client(max_retries=2))
    assert err.kind == "empty"
    assert fake.count == 3
    # Tokens spent on the empty answers are still accounted.
    assert err.extra["completion_tokens"] == 3 * 7


def test_empty_then_text_succeeds_and_sums_tokens(fake, make_client):
    fake.program(ok(""), ok("REASON: ok\nACTION: 3"))
    reply = ask(make_client())
    assert reply.retries == 1
    assert reply.completion_tokens == 14


# -- client errors fail fast ---------------------------------------------------------------


def refused(status: int) -> Behaviour:
    return error(status, "nope", err_type="invalid_request_error")


@pytest.mark.parametrize(
    ("behaviour", "kind"),
    [(BAD_REQUEST, "bad_request"), (CONTEXT_WINDOW, "context_window"), (refused(401), "auth"),
     (refused(403), "auth"), (refused(404), "not_found"), (refused(422), "bad_request")],
    ids=["400", "400-context-window", "401", "403", "404", "422"],
)  # fmt: skip
def test_client_errors_fail_fast(fake, make_client, behaviour, kind):
    fake.program(default=behaviour)
    err = fails(make_client())
    assert err.kind == kind
    assert err.retries == 0
    assert fake.count == 1


def test_unreachable_server_is_transient(make_client):
    # Port 9 on loopback (discard) is closed on a test machine: connection refused at once.
    err = fails(make_client(api_base="http://127.0.0.1:9/v1", max_retries=1, timeout_s=2.0))
    assert err.kind == "transient"
    assert err.retries == 1


# -- replies are returned raw, but capped ----------------------------------------------------


def test_malformed_reply_is_returned_as_is(fake, make_client):
    fake.program(ok("I think I'll go with the knife, maybe?? {not: json"))
    reply = ask(make_client())
    assert reply.text == "I think I'll go with the knife, maybe?? {not: json"
    assert fake.count == 1  # parsing is the planner's job: no retry


def test_oversized_reply_is_truncated_and_flagged(fake, make_client):
    fake.program(ok("REASON: " + "x" * 200_000 + "\nACTION: 1"))
    reply = ask(make_client(max_reply_chars=1000))
    assert reply.text == "REASON: " + "x" * 992  # the model's own text, nothing added
    assert reply.truncated_chars == 199_018  # 200_018 - 1_000
    assert ask(make_client()).truncated_chars == 0


# -- what is sent --------------------------------------------------------------------------


def test_payload_in_text_mode(fake, make_client, fake_key):
    ask(make_client())
    body = fake.requests[0]
    assert body["messages"] == [{"role": "user", "content": "Pick an action."}]
    assert body["model"] == "fake-model"
    assert "temperature" not in body  # "auto": only gpt/o1/o3/o4 models get 0
    assert "max_tokens" not in body and "seed" not in body and "grammar" not in body
    assert fake.headers[0]["authorization"] == f"Bearer {fake_key}"


def test_payload_in_image_mode(fake, make_client):
    png = b"\x89PNG\r\n\x1a\nfake-frame"
    ask(make_client(), ModelRequest(prompt="Look.", images=(png, png + b"2")))
    (message,) = fake.requests[0]["messages"]
    text, first, second = message["content"]
    assert text == {"type": "text", "text": "Look."}
    assert first["type"] == "image_url"
    url = first["image_url"]["url"]
    assert url.startswith("data:image/png;base64,")
    assert base64.b64decode(url.split(",", 1)[1]) == png
    assert second["image_url"]["url"] != url


def test_a_prompt_of_content_parts_is_sent_as_its_parts_then_the_frames(fake, make_client):
    """A chat prompt (content parts, as a strategy may give one) keeps its parts, the frames
    after them; its text asks for a MSG: line as a text prompt does."""
    png = b"\x89PNG\r\n\x1a\nfake-frame"
    parts = [{"type": "text", "text": "Look at the frame."},
             {"type": "text", "text": "Reply with MSG: too"}]
    menu = (MenuOption(3, "PickUp", "PickUp(a)"),)
    request = ModelRequest(prompt=parts, images=(png,), menu=menu)
    assert request_problem(request) is None
    ask(make_client(grammar=True), request)
    (message,) = fake.requests[0]["messages"]
    assert message["content"][:2] == parts
    assert [part["type"] for part in message["content"]] == ["text", "text", "image_url"]
    assert '"\\nMSG: "' in fake.requests[0]["grammar"]
    ask(make_client(), ModelRequest(prompt=parts[:1]))
    assert fake.requests[1]["messages"] == [{"role": "user", "content": parts[:1]}]


def test_sampling_parameters_and_extra_params(fake, make_client):
    client = make_client(
        temperature=0.7, max_tokens=64, seed=5, extra_params={"top_p": 0.5, "extra_body": {"k": 1}}
    )
    ask(client, ModelRequest(prompt="p", sample_index=2))
    body = fake.requests[0]
    assert body["temperature"] == 0.7
    assert body["max_tokens"] == 64
    assert body["seed"] == 7  # seed + sample_index
    assert body["top_p"] == 0.5
    assert body["k"] == 1  # extra_body is merged into the JSON body


def test_reference_temperature_for_gpt_models(fake, make_client):
    ask(make_client("openai/gpt-4o-mini"))
    assert fake.requests[0]["temperature"] == 0
    ask(make_client("openai/fake-model", temperature=None))
    assert "temperature" not in fake.requests[1]


def test_known_model_has_a_cost(fake, make_client):
    reply = ask(make_client("openai/gpt-4o-mini"))
    assert reply.cost_usd > 0  # priced from LiteLLM's local cost map


def test_grammar_is_sent_in_the_body(fake, make_client):
    menu = (MenuOption(3, "PickUp", "PickUp(a)"), MenuOption(12, "Find", "Find(b)"))
    ask(make_client(grammar=True), ModelRequest(prompt="Choose.", menu=menu))
    grammar = fake.requests[0]["grammar"]
    assert '"12" | "3" | "DONE"' in grammar
    assert "MSG" not in grammar
    ask(make_client(grammar=True), ModelRequest(prompt="Reply with MSG: too", menu=menu))
    assert '"\\nMSG: "' in fake.requests[1]["grammar"]
