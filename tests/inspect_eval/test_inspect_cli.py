"""`inspect eval cocobench_agents/cocobench` as a user types it, in its own process: the docs'
first command on a fresh machine with nothing cached and no network; a dead endpoint and a
text-only model under an image condition stopped by the task's pre-flight before any sample,
in seconds, with the provider's words and a non-zero exit, as `cocobench run` stops them."""

from __future__ import annotations

import json
import socket
import subprocess
import time
from pathlib import Path

import pytest

from tests.faults.test_model_faults import LLAMA_NO_IMAGES, Provider, _has_image

from .conftest import inspect_command, openai_api, subprocess_env

pytestmark = [pytest.mark.needs_inspect, pytest.mark.slow]

#: The demo instance the docs' first command plays.
FIRST_COMMAND = ["eval", "cocobench_agents/cocobench", "--model", "mockllm/model",
                 "-T", "task=demo", "-T", "conditions=C0_blind", "-T", "max_steps=4"]
#: A proxy nothing listens on: anything the command tries to download fails at once.
NO_NETWORK = "http://127.0.0.1:9"
#: Inspect's provider for an OpenAI-compatible server reads FAKE_BASE_URL and FAKE_API_KEY
#: for the models ``openai-api/fake/NAME`` (in a process of its own: in this one, each test
#: takes a service name of its own, `openai_api`).
SERVICE = "fake"


def fresh_machine(tmp_path: Path) -> dict[str, str]:
    """A newcomer's environment: an empty home, cache and temporary folder, no tokenizer
    folder chosen, and no network (every download goes to a dead proxy; 127.0.0.1 is
    reached directly)."""
    env = {k: v for k, v in subprocess_env(checkout_first=False).items()
           if k not in ("TIKTOKEN_CACHE_DIR", "DATA_GYM_CACHE_DIR", "NO_PROXY", "no_proxy")}
    for name in ("home", "cache", "tmp"):
        (tmp_path / name).mkdir()
    env.update(HOME=str(tmp_path / "home"), XDG_CACHE_HOME=str(tmp_path / "cache"),
               TMPDIR=str(tmp_path / "tmp"), HTTPS_PROXY=NO_NETWORK, HTTP_PROXY=NO_NETWORK,
               https_proxy=NO_NETWORK, http_proxy=NO_NETWORK, NO_PROXY="127.0.0.1,localhost",
               no_proxy="127.0.0.1,localhost")
    return env


def inspect(args: list[str], env: dict[str, str], log_dir: Path
            ) -> tuple[subprocess.CompletedProcess[str], float]:
    """The command's result and how long it took (``COLUMNS`` wide enough that Inspect
    prints a message on one line)."""
    start = time.monotonic()
    done = subprocess.run([*inspect_command(), *args, "--log-dir", str(log_dir),
                           "--display", "plain"], capture_output=True, text=True,
                          env={**env, "COLUMNS": "1000"}, timeout=240, check=False)
    return done, time.monotonic() - start


@pytest.fixture(scope="module")
def first_eval(tmp_path_factory) -> tuple[subprocess.CompletedProcess[str], Path, Path]:
    """The docs' first command on a fresh machine: its result, its log and the machine."""
    from inspect_ai.log import list_eval_logs

    machine = tmp_path_factory.mktemp("fresh")
    done, _ = inspect(FIRST_COMMAND, fresh_machine(machine), machine / "logs")
    logs = list_eval_logs(str(machine / "logs"))
    return done, Path(logs[0].name.removeprefix("file://")) if logs else machine, machine


def test_the_docs_first_command_runs_on_a_fresh_offline_machine(first_eval):
    from inspect_ai.log import read_eval_log

    done, log_file, tmp_path = first_eval
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    log = read_eval_log(str(log_file))
    assert log.status == "success", log.error
    assert log.samples and not [s.error for s in log.samples if s.error]
    # mockllm counted the prompts' tokens with o200k_base, found without a download
    assert all(usage.input_tokens > 100 for s in log.samples for usage in
               s.model_usage.values())
    assert not any((tmp_path / "tmp").iterdir())  # nothing fetched into tiktoken's default


def test_inspect_score_rescores_a_log_by_the_scorer_it_names(first_eval, tmp_path: Path):
    """``inspect score LOG`` as Inspect users type it: the log names the scorer without its
    package (``cocobench_scorer``), which Inspect finds (it asked for ``--scorer``)."""
    from inspect_ai.log import read_eval_log

    _, log_file, _ = first_eval
    rescored = tmp_path / "rescored.eval"
    done = subprocess.run([*inspect_command(), "score", str(log_file), "--action", "overwrite",
                           "--output-file", str(rescored), "--display", "plain"],
                          capture_output=True, text=True, timeout=240, check=False,
                          env={**fresh_machine(tmp_path), "COLUMNS": "1000"})
    assert done.returncode == 0 and "couldn't be loaded" not in done.stdout, done.stdout[-2000:]
    before, after = read_eval_log(str(log_file)), read_eval_log(str(rescored))
    values = [[s.scores["cocobench_scorer"].value for s in log.samples]
              for log in (before, after)]
    assert json.dumps(values[0]) == json.dumps(values[1])  # NaN where unscored, alike
    assert {score.name for score in after.results.scores} >= {"success", "construct_score"}


def closed_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def preflight_of(tmp_path: Path, model: str, conditions: str, monkeypatch) -> tuple[str, float]:
    """`eval()` of the task by its function, as ``inspect eval`` builds it: the message the
    pre-flight stopped it with, and how long that took (no log written)."""
    from inspect_ai import eval as inspect_eval

    from cocobench_agents.inspect_eval.params import TaskParameterError
    from cocobench_agents.inspect_eval.task import cocobench

    start = time.monotonic()
    with pytest.raises(TaskParameterError) as stopped:
        inspect_eval(cocobench, task_args={"task": "demo", "conditions": conditions},
                     model=model, log_dir=str(tmp_path / "logs"), display="none")
    assert not list((tmp_path / "logs").glob("*.eval"))
    return str(stopped.value), time.monotonic() - start


def test_a_dead_endpoint_stops_the_eval_before_any_sample(tmp_path: Path, monkeypatch):
    model = f"{openai_api(monkeypatch, f'http://127.0.0.1:{closed_port()}/v1')}/healthy"
    message, took = preflight_of(tmp_path, model, "C0_blind", monkeypatch)
    assert took < 30, took
    assert message.startswith("pre-flight call failed (no sample was started; "
                              "-T preflight=false skips this check): "
                              f"{model} (text only): transient: "), message
    assert "APIConnectionError: Connection error. (ConnectError: " in message


@pytest.fixture
def provider():
    with Provider() as server:
        server.image_refusal = LLAMA_NO_IMAGES  # llama.cpp without its --mmproj
        yield server


def test_a_text_only_model_under_an_image_condition_is_stopped_with_its_words(
        tmp_path: Path, provider: Provider, monkeypatch):
    model = f"{openai_api(monkeypatch, provider.base_url)}/text-only"
    message, took = preflight_of(tmp_path, model, "C0_image,C0_blind", monkeypatch)
    assert took < 30, took
    # the image's probe failed with the server's words; the text-only one passed
    assert f"{model} (with an image): unsupported_input: " in message, message
    assert "image input is not supported" in message and "mmproj" in message
    assert "(text only)" not in message
    # the probes carry their own small token cap; Inspect did not retry the refusal (its
    # provider's client, OpenAI's SDK, tries a 500 three times)
    images = [body for body in provider.requests if _has_image(body)]
    assert 1 <= len(images) <= 3 and len(provider.requests) == len(images) + 1
    assert all(probe["max_tokens"] == 16 for probe in provider.requests)


def test_the_command_line_exits_non_zero_with_the_providers_words(tmp_path: Path,
                                                                   provider: Provider):
    env = {**fresh_machine(tmp_path), f"{SERVICE.upper()}_BASE_URL": provider.base_url,
           f"{SERVICE.upper()}_API_KEY": "sk-fake-inspect-0001"}
    model = f"openai-api/{SERVICE}/text-only"
    args = ["eval", "cocobench_agents/cocobench", "--model", model, "-T", "task=demo",
            "-T", "task_id=G_D1__DemoLivingRoom1__seed0", "-T", "max_steps=2"]
    done, _ = inspect([*args, "-T", "conditions=C0_image"], env, tmp_path / "image")
    assert done.returncode == 1 and "Traceback" not in done.stderr
    message = done.stdout.strip()  # the message alone
    assert message.startswith("pre-flight call failed (no sample was started; "), message
    assert f"{model} (with an image): unsupported_input: " in message
    assert "image input is not supported" in message
    assert not list((tmp_path / "image").glob("*.eval"))
    # blind, the same model passes its pre-flight (no image) and plays
    provider.program()
    done, _ = inspect([*args, "-T", "conditions=C0_blind"], env, tmp_path / "blind")
    assert done.returncode == 0, done.stdout[-3000:]
    assert provider.requests[0]["max_tokens"] == 16  # the probe
    assert all("max_tokens" not in body for body in provider.requests[1:])  # the decisions


def test_the_preflight_can_be_skipped(tmp_path: Path, provider: Provider):
    """``-T preflight=false``: the samples run, and each fails on the refused image, after
    Inspect's bounded retries: the sample names the provider's words."""
    from inspect_ai.log import list_eval_logs, read_eval_log

    env = {**fresh_machine(tmp_path), f"{SERVICE.upper()}_BASE_URL": provider.base_url,
           f"{SERVICE.upper()}_API_KEY": "sk-fake-inspect-0001"}
    _, took = inspect(["eval", "cocobench_agents/cocobench", "--model",
                          f"openai-api/{SERVICE}/text-only", "-T", "task=demo",
                          "-T", "task_id=G_D1__DemoLivingRoom1__seed0",
                          "-T", "conditions=C0_image", "-T", "preflight=false"],
                         env, tmp_path / "logs")
    assert took < 60, took
    [info] = list_eval_logs(str(tmp_path / "logs"))
    [sample] = read_eval_log(info).samples
    assert sample.error is not None and "image input is not supported" in sample.error.message
