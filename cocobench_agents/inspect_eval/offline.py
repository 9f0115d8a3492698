"""The tokenizer Inspect needs offline: its `mockllm` (the model of the docs' first command)
and its token estimates count with tiktoken's ``o200k_base``, which tiktoken downloads on
first use into its cache folder. LiteLLM (a dependency) ships that file under the name
tiktoken's cache gives it (the SHA-1 of its URL), so pointing ``TIKTOKEN_CACHE_DIR`` at
LiteLLM's copy lets a fresh machine with no network run the task (LiteLLM does the same
when it is imported). A folder the user chose (``TIKTOKEN_CACHE_DIR``, ``DATA_GYM_CACHE_DIR``)
is left alone."""

from __future__ import annotations

import hashlib
import importlib.util
import os
from pathlib import Path

#: The encoding Inspect counts with, and where tiktoken fetches it from.
ENCODING_URL = "https://openaipublic.blob.core.windows.net/encodings/o200k_base.tiktoken"
#: The variables naming tiktoken's cache folder, in the order tiktoken reads them.
CACHE_VARIABLES = ("TIKTOKEN_CACHE_DIR", "DATA_GYM_CACHE_DIR")


def cache_file_name(url: str = ENCODING_URL) -> str:
    """The name tiktoken's cache gives the file fetched from `url`."""
    return hashlib.sha1(url.encode()).hexdigest()


def bundled_tokenizers() -> Path | None:
    """LiteLLM's folder of tiktoken files when it holds ``o200k_base``, found without
    importing LiteLLM (slow to import); None otherwise."""
    spec = importlib.util.find_spec("litellm")
    if spec is None or spec.origin is None:
        return None
    folder = Path(spec.origin).parent / "litellm_core_utils" / "tokenizers"
    return folder if (folder / cache_file_name()).is_file() else None


def use_bundled_tokenizer() -> None:
    """Point tiktoken's cache at LiteLLM's copy, unless a cache folder is already chosen or
    there is no copy."""
    if any(name in os.environ for name in CACHE_VARIABLES):
        return
    folder = bundled_tokenizers()
    if folder is not None:
        os.environ["TIKTOKEN_CACHE_DIR"] = str(folder)
