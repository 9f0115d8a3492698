"""Image conditions against a model that sees images: the colour server of
``../shared/tools/colour-vlm/`` (tests/models/colour_vlm.py). Through LiteLLM, the http
transport and Inspect, a frame reaches the model (it names the frame's colour, and the image
adds its 16 prompt tokens); a C0_image episode plays alike through the three, each decision's
prompt counted alike; the dry run's count of a C0_image first prompt is set against the
server's, text and frame apart; the same server without its projector is refused by the
pre-flight of both doors with the server's words."""

from __future__ import annotations

import asyncio
import io
import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from tests.models.colour_vlm import (
    DRY_RUN_FRAME_TOKENS,
    IMAGE_TOKENS,
    build_projector,
    start_colour_server,
)
from tests.paths import SHARED_TASKS

pytestmark = [pytest.mark.vlm, pytest.mark.slow]

QUESTION = "What colour is this image? Answer with one word."
TASK = str(SHARED_TASKS / "A_D1__FloorPlan1__seed0.json")
SERVICE = "colour"  # Inspect's openai-api/colour/… reads COLOUR_BASE_URL, COLOUR_API_KEY
KEY = "no-key-required"


@pytest.fixture(scope="module")
def colour_server(tmp_path_factory):
    with start_colour_server(build_projector(tmp_path_factory.mktemp("mmproj"))) as server:
        yield server


@pytest.fixture(scope="module")
def text_only_server():
    with start_colour_server(None) as server:
        yield server


def solid_png(rgb: tuple[int, int, int]) -> bytes:
    from PIL import Image

    buffer = io.BytesIO()
    Image.new("RGB", (64, 64), rgb).save(buffer, format="PNG")
    return buffer.getvalue()


def _client(server, transport: str) -> Any:
    from cocobench_agents.models import ModelPool, ModelSettings

    settings = ModelSettings(api_base=server.base_url, temperature=0, max_tokens=8,
                             transport="http" if transport == "inspect" else transport)
    if transport != "inspect":
        return ModelPool(settings).client(f"openai/{server.model}", episode="vlm", agent=None)
    from inspect_ai.model import get_model

    from cocobench_agents.models.inspect_client import InspectClient

    model = get_model(f"openai-api/{SERVICE}/{server.model}", base_url=server.base_url,
                      api_key=KEY, memoize=False)
    return InspectClient(str(model), settings.model_copy(update={"transport": "inspect"}),
                         inspect_model=model)


@pytest.mark.parametrize("transport", ["litellm", "http",
                                       pytest.param("inspect", marks=pytest.mark.needs_inspect)])
def test_a_frame_reaches_the_model(colour_server, transport):
    from cocobench_agents.models import ModelRequest

    client = _client(colour_server, transport)

    async def ask() -> list[Any]:
        return [await client.complete(ModelRequest(prompt=QUESTION, images=images))
                for images in ((), (solid_png((0, 255, 0)),), (solid_png((255, 0, 0)),))]

    blind, green, red = asyncio.run(ask())
    assert "green" in green.text.lower() and "red" in red.text.lower(), (green, red)
    assert "green" not in blind.text.lower() and "red" not in blind.text.lower()
    assert green.prompt_tokens == red.prompt_tokens == blind.prompt_tokens + IMAGE_TOKENS


def _cocobench_run(server, transport: str, out: Path, conditions: str = "C0_image"
                   ) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "cocobench_agents.cli", "run", "--task", TASK, "--model",
         f"openai/{server.model}", "--api-base", server.base_url, "--transport", transport,
         "--conditions", conditions, "--max-steps", "1", "--max-tokens", "8",
         "--temperature", "0", "--timeout", "300", "--out", str(out)],
        capture_output=True, text=True, check=False, timeout=900)


def _decisions(out: Path) -> list[dict[str, Any]]:
    [line] = [json.loads(x) for x in (out / "results.jsonl").read_text().splitlines()]
    assert not line.get("infra_error") and line["backend_errors"] == 0, line
    return json.loads((out / line["trajectory"]).read_text())["planner_decisions"]


def test_the_dry_runs_image_tokens_against_the_servers_count(colour_server, tmp_path):
    """A C0_image episode's first prompt, as the dry run counts it and as the server counted
    it when the episode ran, each split into its text and its frame: the dry run renders the
    prompt the run sent (its text count is the run's prompt's); it counts the frame by
    OpenAI's tile rule (425 tokens for C0's 600×328 view) where this server adds 16, so its
    image figure is an upper bound for such a server, not the server's count."""
    from cocobench_agents.engine.pricing import TokenCounter
    from cocobench_agents.models import ModelRequest, build_messages, import_litellm
    from cocobench_agents.runfolder import RunFolder

    model = f"openai/{colour_server.model}"
    dry = subprocess.run(
        [sys.executable, "-m", "cocobench_agents.cli", "run", "--task", TASK, "--model", model,
         "--conditions", "C0_image", "--max-steps", "1", "--dry-run", "--json", "--out",
         str(tmp_path / "dry")], capture_output=True, text=True, check=False, timeout=300)
    assert dry.returncode == 0, dry.stderr[-3000:]
    [episode] = json.loads(dry.stdout)["episodes"]
    dry_total = episode["prompt_tokens"]

    out = tmp_path / "run"
    done = _cocobench_run(colour_server, "http", out)
    assert done.returncode == 0, done.stderr[-3000:]
    first = _decisions(out)[0]
    [line] = RunFolder(out).results()
    text = RunFolder(out).prompts(line)[first["prompt_hash"]]
    server_total = first["prompt_tokens"]

    async def server_text_only() -> int:
        reply = await _client(colour_server, "http").complete(ModelRequest(prompt=text))
        return reply.prompt_tokens

    dry_text = TokenCounter(import_litellm(), model).count(
        build_messages(ModelRequest(prompt=text)))
    server_text = asyncio.run(server_text_only())
    # the frame: the dry run's tile rule against the server's 16 tokens
    assert dry_total - dry_text == DRY_RUN_FRAME_TOKENS
    assert server_total - server_text == IMAGE_TOKENS
    # the text: cl100k_base (the dry run's stand-in) within 25 % of SmolLM2's own tokenizer
    assert abs(dry_text - server_text) <= 0.25 * server_text, (dry_text, server_text)
    assert dry_total > server_total  # an upper bound for this server


@pytest.mark.needs_inspect
def test_an_image_episode_plays_alike_through_both_transports_and_inspect(
        colour_server, tmp_path, monkeypatch):
    from inspect_ai import eval as inspect_eval
    from inspect_ai.log import read_eval_log

    from cocobench_agents.inspect_eval.solver import TRAJECTORY
    from cocobench_agents.inspect_eval.task import cocobench

    prompts = {}
    for transport in ("litellm", "http"):
        done = _cocobench_run(colour_server, transport, tmp_path / transport)
        assert done.returncode == 0, done.stderr[-3000:]  # the image pre-flight passed
        prompts[transport] = [d["prompt_tokens"] for d in _decisions(tmp_path / transport)
                              if d.get("raw_output") is not None]
    monkeypatch.setenv(f"{SERVICE.upper()}_BASE_URL", colour_server.base_url)
    monkeypatch.setenv(f"{SERVICE.upper()}_API_KEY", KEY)
    [log] = inspect_eval(cocobench, task_args={"task": TASK, "conditions": "C0_image",
                                               "max_steps": 1, "max_tokens": 8,
                                               "temperature": 0},
                         model=f"openai-api/{SERVICE}/{colour_server.model}",
                         log_dir=str(tmp_path / "logs"), display="none")
    [sample] = read_eval_log(log.location).samples
    assert sample.error is None, sample.error
    prompts["inspect"] = [d["prompt_tokens"] for d in sample.store[TRAJECTORY][
        "planner_decisions"] if d.get("raw_output") is not None]
    # the same prompt and frames reached the model through each door: the same count
    assert prompts["litellm"] and prompts["litellm"] == prompts["http"] == prompts["inspect"]


@pytest.mark.needs_inspect
def test_the_text_only_server_is_refused_by_both_doors_preflight(text_only_server, tmp_path,
                                                                  monkeypatch):
    from inspect_ai import eval as inspect_eval

    from cocobench_agents.inspect_eval.params import TaskParameterError
    from cocobench_agents.inspect_eval.task import cocobench

    out = tmp_path / "run"
    done = _cocobench_run(text_only_server, "http", out)
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert "(with an image)" in done.stderr and "image input is not supported" in done.stderr
    assert not out.exists()
    # another service name: Inspect keeps one model per name (the colour server's)
    monkeypatch.setenv("TEXTONLY_BASE_URL", text_only_server.base_url)
    monkeypatch.setenv("TEXTONLY_API_KEY", KEY)
    with pytest.raises(TaskParameterError) as refused:
        inspect_eval(cocobench, task_args={"task": TASK, "conditions": "C0_image"},
                     model=f"openai-api/textonly/{text_only_server.model}",
                     log_dir=str(tmp_path / "logs"), display="none")
    assert "(with an image): unsupported_input" in str(refused.value)
    assert "image input is not supported" in str(refused.value)
