"""The on-disk response cache, alone and behind `LiteLLMClient`."""

from __future__ import annotations

import asyncio
import json
import threading

import pytest

from cocobench_agents.models import ModelError, ModelReply, ModelRequest, ResponseCache, cache_key

from .fake_openai import BAD_REQUEST, ok

MESSAGES = [{"role": "user", "content": "hello"}]


def ask(client, request):
    return asyncio.run(client.complete(request))


def test_second_identical_request_is_served_from_disk(fake, make_client, tmp_path):
    fake.program(ok("REASON: a\nACTION: 1"), ok("REASON: b\nACTION: 2"))
    request = ModelRequest(prompt="Pick.", images=(b"\x89PNG-frame",))
    first = ask(make_client(cache_dir=tmp_path), request)
    # A new client (a later run) with the same cache folder.
    second = ask(make_client(cache_dir=tmp_path), request)
    assert fake.count == 1
    assert not first.cached and second.cached
    assert second.text == first.text == "REASON: a\nACTION: 1"
    assert (second.prompt_tokens, second.completion_tokens) == (11, 7)
    files = list(tmp_path.rglob("*.json"))
    assert len(files) == 1 and files[0].parent.parent == tmp_path  # sharded: DIR/ab/abcd….json
    assert files[0].parent.name == files[0].stem[:2]


def test_cache_misses_on_sample_prompt_image_and_parameters(fake, make_client, tmp_path):
    client = make_client(cache_dir=tmp_path)
    base = ModelRequest(prompt="Pick.", images=(b"frame-1",))
    ask(client, base)
    ask(client, ModelRequest(prompt="Pick.", images=(b"frame-1",), sample_index=1))
    ask(client, ModelRequest(prompt="Pick!", images=(b"frame-1",)))
    ask(client, ModelRequest(prompt="Pick.", images=(b"frame-2",)))
    ask(make_client(cache_dir=tmp_path, temperature=0.3), base)
    ask(make_client("openai/other-model", cache_dir=tmp_path), base)
    assert fake.count == 6
    ask(client, ModelRequest(prompt="Pick.", images=(b"frame-1",), sample_index=1))
    assert fake.count == 6  # every one of them is now cached


def test_agent_does_not_change_the_key(fake, make_client, tmp_path):
    # What the model sees is the key; two agents with identical prompts share an answer.
    client = make_client(cache_dir=tmp_path)
    ask(client, ModelRequest(prompt="Same.", agent="agent_1"))
    assert ask(client, ModelRequest(prompt="Same.", agent="agent_2")).cached


def test_errors_are_not_cached(fake, make_client, tmp_path):
    fake.program(BAD_REQUEST, ok())
    client = make_client(cache_dir=tmp_path)
    with pytest.raises(ModelError):
        ask(client, ModelRequest(prompt="x"))
    assert not ask(client, ModelRequest(prompt="x")).cached
    assert fake.count == 2


def test_images_are_hashed_in_the_key_not_stored(fake, make_client, tmp_path):
    big = b"\x89PNG" + bytes(range(256)) * 64
    ask(make_client(cache_dir=tmp_path), ModelRequest(prompt="p", images=(big,)))
    (file,) = tmp_path.rglob("*.json")
    assert file.stat().st_size < 2000
    assert "base64" not in file.read_text()


def test_key_depends_on_every_part():
    params = {"temperature": 0}
    key = cache_key("m", MESSAGES, params, 0)
    assert key == cache_key("m", [dict(m) for m in MESSAGES], dict(params), 0)
    assert len({
        key,
        cache_key("m2", MESSAGES, params, 0),
        cache_key("m", [{"role": "user", "content": "bye"}], params, 0),
        cache_key("m", MESSAGES, {"temperature": 1}, 0),
        cache_key("m", MESSAGES, params, 1),
    }) == 5  # fmt: skip


def test_unreadable_or_foreign_files_are_misses(tmp_path):
    cache = ResponseCache(tmp_path)
    key = cache_key("m", MESSAGES, {}, 0)
    assert cache.get(key) is None
    cache.path(key).parent.mkdir(parents=True)
    cache.path(key).write_text("{ truncated")
    assert cache.get(key) is None
    cache.path(key).write_text(json.dumps({"format": 1, "key": "other", "reply": {"text": "x"}}))
    assert cache.get(key) is None
    cache.put(key, ModelReply(text="ok", prompt_tokens=3), model="m", sample_index=0)
    assert cache.get(key) == ModelReply(text="ok", prompt_tokens=3, cached=True)


def test_concurrent_writers_of_one_key_leave_one_complete_file(tmp_path):
    cache = ResponseCache(tmp_path)
    key = cache_key("m", MESSAGES, {}, 0)
    errors: list[BaseException] = []

    def write(i: int) -> None:
        try:
            for j in range(25):
                cache.put(key, ModelReply(text=f"reply {i}-{j} " * 50), model="m", sample_index=0)
                assert cache.get(key) is not None  # never a partial file
        except BaseException as exc:  # noqa: BLE001 - reported below
            errors.append(exc)

    threads = [threading.Thread(target=write, args=(i,)) for i in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors
    assert cache.get(key) is not None
    assert [p.name for p in tmp_path.rglob("*") if p.is_file()] == [f"{key}.json"]  # no temp left


def test_concurrent_identical_async_requests(fake, make_client, tmp_path):
    client = make_client(cache_dir=tmp_path)

    async def many():
        return await asyncio.gather(*(client.complete(ModelRequest("same")) for _ in range(6)))

    replies = asyncio.run(many())
    assert {r.text for r in replies} == {"REASON: fine\nACTION: 1"}
    assert ask(client, ModelRequest("same")).cached
