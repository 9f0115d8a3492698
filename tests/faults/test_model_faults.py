"""Model faults through the whole `cocobench run` / `cocobench report` path, on both transports,
against a fake OpenAI-compatible server on 127.0.0.1 (issue 12: items 1, 8, 9, 13).

A model whose calls all fail is counted as an error everywhere (live line, summary, report)
and the run exits 1 naming the command that retries it; a failing pre-flight call stops the run
before anything is written (exit 2, the provider's message); a text-only model under an image
condition is caught by the pre-flight; the cache is keyed per endpoint and transport, and a
reused reply (cache or replay) is billed 0 with its original cost kept as "saved"; a cache
that cannot be written loses no reply. Issue 26: an input the model does not take is never
retried and, without the pre-flight, stops the run naming its cause and its fix; an occupied
run folder, or a resume at its spend limit, is refused with no call at all; a remote model
sent no temperature is told once on the console and under the summary.
"""

from __future__ import annotations

import asyncio
import json
from pathlib import Path
from typing import Any

import pytest

from cocobench_agents.cli import main
from cocobench_agents.models import ENDPOINT_TRANSPORTS, ModelRequest, ModelSettings, ResponseCache
from cocobench_agents.models.pool import ModelPool
from tests.models.fake_openai import SERVER_ERROR, Behaviour, FakeOpenAI, error, ok

KEY_ENV = "FAKE_PROVIDER_API_KEY"
DONE = "REASON: nothing left to do\nACTION: DONE"
NO_IMAGES = error(400, "Image input is not supported by this model",
                  err_type="invalid_request_error")
# llama.cpp's server without its --mmproj answers an image with a 500, worded so:
LLAMA_NO_IMAGES = error(500, "image input is not supported - hint: if this is unexpected, you "
                        "may need to provide the mmproj")
MISSING = error(404, "The model `missing` does not exist", code="model_not_found",
                err_type="invalid_request_error")


class Provider(FakeOpenAI):
    """Answers by model name: ``behaviours[name]`` (DONE by default); ``text-only`` refuses
    any request with an image."""

    def __init__(self) -> None:
        super().__init__(ok(DONE))
        self.behaviours: dict[str, Behaviour] = {}
        self.image_refusal = NO_IMAGES  # how ``text-only`` refuses an image

    def _next(self, body: dict[str, Any], headers: dict[str, str]) -> Behaviour:
        super()._next(body, headers)
        name = body.get("model", "")
        if name == "text-only" and _has_image(body):
            return self.image_refusal
        return self.behaviours.get(name, self.default)


def _has_image(body: dict[str, Any]) -> bool:
    return any(isinstance(m.get("content"), list)
               and any(part.get("type") == "image_url" for part in m["content"])
               for m in body.get("messages", []))


@pytest.fixture(scope="module")
def provider():
    with Provider() as server:
        yield server


@pytest.fixture
def server(provider: Provider, monkeypatch, tmp_path):
    monkeypatch.setenv(KEY_ENV, "sk-fake-model-faults-0001")
    monkeypatch.chdir(tmp_path)  # no .env of the checkout
    provider.behaviours.clear()
    provider.image_refusal = NO_IMAGES
    return provider.program(default=ok(DONE))


@pytest.fixture(params=ENDPOINT_TRANSPORTS)
def transport(request) -> str:
    return request.param


def cocobench(server: Provider, transport: str, out: Path, *args: str,
              capsys=None) -> tuple[int, str, str]:
    """Run `cocobench run` in this process; (exit code, stdout, stderr)."""
    code = main(["run", "--suite", "demo", "--limit", "2", "--obs", "blind", "--out", str(out),
                 "--api-base", server.base_url, "--api-key-env", KEY_ENV,
                 "--transport", transport, "--max-retries", "1", "--timeout", "5", *args])
    captured = capsys.readouterr() if capsys is not None else None
    return code, captured.out if captured else "", captured.err if captured else ""


def results(out: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in (out / "results.jsonl").read_text().splitlines()]


def summary_errors(stdout: str, model: str) -> str:
    row = next(line for line in stdout.splitlines() if line.startswith(model))
    return row.split()[-1]


# -- every call failing ------------------------------------------------------------------------

def test_a_run_whose_every_call_fails_is_counted_and_exits_1(server, transport, tmp_path,
                                                             capsys):
    server.behaviours["always-500"] = SERVER_ERROR
    out = tmp_path / "run"
    code, stdout, stderr = cocobench(server, transport, out, "--model", "openai/always-500",
                                     "--no-preflight", capsys=capsys)
    assert code == 1
    assert all(r["backend_errors"] > 0 and r["terminal_reason"] == "backend_error"
               for r in results(out))
    assert "errors 2" in stderr  # the live line
    assert summary_errors(stdout, "openai/always-500") == "2"  # the summary's errors column
    assert "2 episodes ended on an infrastructure error" in stderr
    assert f"cocobench run --out {out} --resume --retry-errors" in stderr

    # The report warns above its main table, with the same count and command.
    assert main(["report", str(out), "--out", str(tmp_path / "report"), "--no-plots",
                 "--resamples", "50"]) == 0
    main_table = (tmp_path / "report" / "main_results.md").read_text()
    assert main_table.index("**Warning:** 2 of 2 episodes ended on an infrastructure error") \
        < main_table.index("| Model")
    assert "--resume --retry-errors" in main_table

    # Once the backend is healthy, the retry command completes the run: exit 0, no errors.
    server.behaviours.clear()
    capsys.readouterr()
    code, stdout, _ = cocobench(server, transport, out, "--model", "openai/always-500",
                                "--resume", "--retry-errors", capsys=capsys)
    assert code == 0
    assert summary_errors(stdout, "openai/always-500") == "0"


def test_a_failed_call_in_the_round_a_teammate_ends_is_still_an_error(server, transport,
                                                                      tmp_path, capsys):
    # agent_1's call fails while agent_2 says DONE: the round ends the episode, so no step
    # records agent_1's decision and the reference's backend_errors stays 0; the call still
    # got no answer, so the episode does not measure the model.
    server.behaviours["always-500"] = SERVER_ERROR
    out = tmp_path / "run"
    code, stdout, stderr = cocobench(server, transport, out, "--planner", "D0",
                                     "--model", "openai/done",
                                     "--agent-model", "agent_1=openai/always-500",
                                     "--no-preflight", capsys=capsys)
    records = results(out)
    assert [(r["backend_errors"], r["usage"]["backend_errors"]) for r in records] == \
        [(0, 1), (0, 1)]
    assert code == 1
    assert "errors 2" in stderr and f"--out {out} --resume --retry-errors" in stderr
    row = next(line for line in stdout.splitlines() if "D0_blind" in line)
    assert row.split()[-1] == "2", row  # the summary's errors column


# -- pre-flight -----------------------------------------------------------------------------------

@pytest.mark.parametrize(("model", "behaviour", "message"), [
    ("missing", MISSING, "The model `missing` does not exist"),
    ("always-500", SERVER_ERROR, "The server had an error while processing your request"),
])
def test_a_failing_preflight_stops_the_run_before_anything_is_written(
        server, transport, tmp_path, capsys, model, behaviour, message):
    server.behaviours[model] = behaviour
    out = tmp_path / "run"
    code, _, stderr = cocobench(server, transport, out, "--model", f"openai/{model}",
                                capsys=capsys)
    assert code == 2
    assert message in stderr and "pre-flight" in stderr and "Traceback" not in stderr
    assert len(stderr.strip().splitlines()) == 1
    assert not out.exists()  # no run folder for a run that never started
    attempts = 2 if behaviour.status >= 500 else 1  # transient errors are retried
    assert server.count == attempts


def test_the_preflight_catches_a_text_only_model_under_an_image_condition(
        server, transport, tmp_path, capsys):
    out = tmp_path / "image"
    code, _, stderr = cocobench(server, transport, out, "--model", "openai/text-only",
                                "--obs", "image", capsys=capsys)
    assert code == 2
    assert "openai/text-only (with an image)" in stderr
    assert "Image input is not supported" in stderr
    assert not out.exists()
    # Blind, the same model passes its pre-flight (sent without an image) and runs.
    code, _, _ = cocobench(server, transport, tmp_path / "blind", "--model", "openai/text-only",
                           capsys=capsys)
    assert code == 0


@pytest.mark.parametrize("refusal", [NO_IMAGES, LLAMA_NO_IMAGES], ids=["400", "llama.cpp-500"])
def test_an_image_refused_by_a_text_only_model_is_not_retried(
        server, transport, tmp_path, capsys, refusal):
    server.image_refusal = refusal
    out = tmp_path / "image"
    code, _, stderr = cocobench(server, transport, out, "--model", "openai/text-only",
                                "--obs", "image", "--max-retries", "2", capsys=capsys)
    assert code == 2
    assert "unsupported_input" in stderr and refusal.body["error"]["message"] in stderr
    assert "attempts" not in stderr and not out.exists()
    # the pre-flight's one call with an image: a permanent error is not retried
    assert sum(map(_has_image, server.requests)) == 1


def test_without_the_preflight_a_refused_image_stops_the_run_naming_its_cause(
        server, transport, tmp_path, capsys):
    server.image_refusal = LLAMA_NO_IMAGES
    out = tmp_path / "image"
    code, _, stderr = cocobench(server, transport, out, "--model", "openai/text-only",
                                "--obs", "image", "--no-preflight", "--jobs", "1",
                                capsys=capsys)
    assert code == 1 and "Traceback" not in stderr
    # the last line: the cause, what to fix, and the command that completes the run
    message = stderr.strip().splitlines()[-1]
    assert "openai/text-only: the model does not take the input sent" in message
    assert "image input is not supported" in message and "--mmproj" in message
    assert f"cocobench run --out {out} --resume --retry-errors" in message
    # the image's one call failed, not retried, and no episode started after it
    assert sum(map(_has_image, server.requests)) == 1
    assert results(out)[-1]["terminal_reason"] == "backend_error"
    assert len(results(out)) < 4


def test_an_occupied_run_folder_is_refused_before_any_call(server, transport, tmp_path,
                                                           capsys):
    out = tmp_path / "run"
    assert cocobench(server, transport, out, "--model", "openai/healthy", capsys=capsys)[0] == 0
    server.program()
    code, _, stderr = cocobench(server, transport, out, "--model", "openai/healthy",
                                capsys=capsys)
    assert code == 2 and "already holds a run" in stderr
    assert server.count == 0  # not even the pre-flight


def test_a_resume_already_at_its_spend_limit_calls_nothing(server, transport, tmp_path,
                                                           capsys):
    out = tmp_path / "run"
    limited = ("--model", "openai/healthy", "--max-total-tokens", "1", "--jobs", "1")
    code, _, stderr = cocobench(server, transport, out, *limited, capsys=capsys)
    assert code == 3 and "spend limit reached" in stderr  # after the first episode
    server.program()
    code, _, stderr = cocobench(server, transport, out, *limited, "--resume", capsys=capsys)
    assert code == 3 and "spend limit reached" in stderr
    assert server.count == 0  # not even the pre-flight


def test_no_preflight_for_builtins_or_a_finished_run(server, transport, tmp_path, capsys):
    out = tmp_path / "run"
    assert cocobench(server, transport, out, "--model", "openai/healthy", capsys=capsys)[0] == 0
    assert server.count == 1 + 2  # the pre-flight, then one DONE per episode
    server.program()
    assert cocobench(server, transport, out, "--model", "openai/healthy", "--resume",
                     capsys=capsys)[0] == 0
    assert server.count == 0  # nothing pending: no call at all
    assert cocobench(server, transport, tmp_path / "greedy", "--model", "greedy",
                     capsys=capsys)[0] == 0
    assert server.count == 0


# -- sampling left to the provider -------------------------------------------------------------

def test_unset_sampling_is_told_once_on_the_console_and_in_the_summary(
        server, transport, tmp_path, capsys):
    code, stdout, stderr = cocobench(server, transport, tmp_path / "auto", "--model",
                                     "openai/qwen-local", capsys=capsys)
    assert code == 0
    assert all("temperature" not in body for body in server.requests)
    told = ("sampling is unset for openai/qwen-local: no temperature is sent (--temperature "
            "auto sends 0 only to gpt/o1/o3/o4 names)")
    assert stderr.count(told) == 1 and f"note: {told}" in stdout
    assert "--temperature 0 fixes it" in stdout

    server.program()
    code, stdout, stderr = cocobench(server, transport, tmp_path / "fixed", "--model",
                                     "openai/qwen-local", "--temperature", "0", capsys=capsys)
    assert code == 0 and all(body["temperature"] == 0 for body in server.requests)
    assert "sampling is unset" not in stdout + stderr


@pytest.mark.parametrize("args", [("--model", "openai/gpt-4o-mini"),
                                  ("--model", "openai/qwen-local", "--extra",
                                   '{"temperature": 0.2}'),
                                  ("--model", "greedy")], ids=["auto-gpt", "extra", "builtin"])
def test_no_sampling_notice_when_the_temperature_is_set_or_nothing_samples(
        server, transport, tmp_path, capsys, args):
    code, stdout, stderr = cocobench(server, transport, tmp_path / "run", *args,
                                     capsys=capsys)
    assert code == 0 and "sampling is unset" not in stdout + stderr


# -- the cache and replays --------------------------------------------------------------------

def test_the_cache_key_covers_the_endpoint_and_the_transport(fake_key_env, tmp_path):
    request = ModelRequest(prompt="Pick one.")
    with Provider() as first, Provider() as second:
        first.program(default=ok("REASON: first\nACTION: 1"))
        second.program(default=ok("REASON: second\nACTION: 1"))

        def ask(server: Provider, transport: str) -> str:
            settings = ModelSettings(api_base=server.base_url, api_key_env=KEY_ENV,
                                     cache_dir=tmp_path / "cache", transport=transport)
            client = ModelPool(settings).client("openai/same-name", episode="e", agent=None)
            return asyncio.run(client.complete(request)).text

        assert ask(first, "http") == "REASON: first\nACTION: 1"
        assert ask(second, "http") == "REASON: second\nACTION: 1"  # not the first's reply
        assert ask(first, "litellm") == "REASON: first\nACTION: 1"
        assert (first.count, second.count) == (2, 1)  # one call per endpoint and transport
        assert ask(second, "http") == "REASON: second\nACTION: 1"
        assert second.count == 1  # the same endpoint hits


@pytest.fixture
def fake_key_env(monkeypatch):
    monkeypatch.setenv(KEY_ENV, "sk-fake-model-faults-0001")


def _usage(out: Path) -> dict[str, dict[str, Any]]:
    return {r["task_id"]: r["usage"] for r in results(out)}


def _decisions(out: Path) -> list[dict[str, Any]]:
    return [d for r in results(out)
            for d in json.loads((out / r["trajectory"]).read_text())["planner_decisions"]]


def test_cache_hits_and_replays_cost_nothing_and_show_what_they_saved(
        server, transport, tmp_path, capsys):
    # A priced model name, so the original calls have a cost.
    model, cache = "openai/gpt-4o-mini", str(tmp_path / "cache")
    first, cached, replayed = tmp_path / "first", tmp_path / "cached", tmp_path / "replayed"
    assert cocobench(server, transport, first, "--model", model, "--cache", cache,
                     capsys=capsys)[0] == 0
    paid = _usage(first)
    assert all(u["prompt_tokens"] == 11 and u["cost_usd"] > 0 for u in paid.values())
    assert all(u["reused_calls"] == 0 and u["saved_cost_usd"] == 0 for u in paid.values())

    calls = server.count
    assert cocobench(server, transport, cached, "--model", model, "--cache", cache,
                     capsys=capsys)[0] == 0
    assert server.count == calls + 1  # the pre-flight only: it bypasses the cache
    assert cocobench(server, transport, replayed, "--model", f"replay:{first}",
                     capsys=capsys)[0] == 0
    for out, flag in ((cached, "cached"), (replayed, "replayed")):
        for task, usage in _usage(out).items():
            assert usage["prompt_tokens"] == usage["completion_tokens"] == 0
            assert usage["cost_usd"] == 0 and usage["model_latency_s"] == 0
            assert usage["reused_calls"] == usage["model_calls"] == 1
            assert usage["saved_cost_usd"] == paid[task]["cost_usd"]
        for decision in _decisions(out):
            assert decision[flag] is True
            assert decision["cost_usd"] == 0 and decision["saved"]["prompt_tokens"] == 11
    assert all(not d["cached"] and not d["replayed"] and "saved" not in d
               for d in _decisions(first))

    # The report's cost table bills the reused calls 0 and shows the saving.
    assert main(["report", str(first), "--out", str(tmp_path / "report"), "--no-plots",
                 "--resamples", "50"]) == 0
    assert main(["report", str(cached), "--out", str(tmp_path / "report2"), "--no-plots",
                 "--resamples", "50"]) == 0
    rows = (tmp_path / "report2" / "cost.csv").read_text().splitlines()
    header, row = rows[0].split(","), rows[1].split(",")
    assert float(row[header.index("cost_usd_total")]) == 0
    assert float(row[header.index("saved_cost_usd_total")]) == pytest.approx(
        sum(u["cost_usd"] for u in paid.values()), abs=1e-6)


def test_a_cache_that_cannot_be_written_loses_no_reply(server, transport, tmp_path):
    blocker = tmp_path / "not-a-folder"
    blocker.write_text("a file where the cache folder should be")
    settings = ModelSettings(api_base=server.base_url, api_key_env=KEY_ENV,
                             cache_dir=blocker / "cache", transport=transport)
    pool = ModelPool(settings)
    client = pool.client("openai/healthy", episode="e", agent=None)

    async def ask_twice():
        return [await client.complete(ModelRequest(prompt=p)) for p in ("one", "two")]

    with pytest.warns(RuntimeWarning, match="cannot be written") as warned:
        replies = asyncio.run(ask_twice())
    assert [r.text for r in replies] == [DONE, DONE]  # both replies kept
    assert server.count == 2
    assert isinstance(pool.cache, ResponseCache) and pool.cache.write_failures == 2
    assert len([w for w in warned if "cannot be written" in str(w.message)]) == 1  # once


def test_run_json_records_the_temperature_actually_sent(server, transport, tmp_path, capsys):
    out = tmp_path / "run"
    assert cocobench(server, transport, out, "--model", "openai/gpt-4o-mini", "--model",
                     "openai/healthy", capsys=capsys)[0] == 0
    record = json.loads((out / "run.json").read_text())
    assert record["request"]["model_settings"]["temperature"] == "auto"
    assert record["temperature_sent"] == {"openai/gpt-4o-mini": 0.0, "openai/healthy": None}
    sent = {body["model"]: body.get("temperature", "none") for body in server.requests}
    assert sent == {"gpt-4o-mini": 0.0, "healthy": "none"}  # as recorded
