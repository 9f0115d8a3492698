"""What can be told about a LiteLLM model string without importing LiteLLM (seconds): its
provider, from the cost map LiteLLM ships, and the API key variable of the common providers.

Used so that the usual mistakes (an unknown bare model name, a missing key) are reported at
once; everything else is still checked by LiteLLM itself.
"""

from __future__ import annotations

import functools
import importlib.util
from pathlib import Path
from typing import Any

import orjson

#: The key variables LiteLLM reads for a provider, any one of which will do (kept in step
#: with `litellm.validate_environment` by a test).
KEY_VARIABLES = {
    "openai": ("OPENAI_API_KEY",),
    "anthropic": ("ANTHROPIC_API_KEY",),
    "gemini": ("GEMINI_API_KEY", "GOOGLE_API_KEY"),
    "mistral": ("MISTRAL_API_KEY",),
    "groq": ("GROQ_API_KEY",),
    "deepseek": ("DEEPSEEK_API_KEY",),
    "xai": ("XAI_API_KEY",),
    "openrouter": ("OPENROUTER_API_KEY",),
}


@functools.cache
def litellm_cost_map() -> dict[str, Any]:
    """The cost map LiteLLM ships (the one it loads offline), read without importing LiteLLM:
    that takes seconds, in every worker process, while this file parses in milliseconds."""
    spec = importlib.util.find_spec("litellm")
    if spec is None or spec.origin is None:
        return {}
    path = Path(spec.origin).parent / "model_prices_and_context_window_backup.json"
    try:
        return orjson.loads(path.read_bytes())
    except (OSError, orjson.JSONDecodeError):
        return {}


def known_provider(model: str) -> str | None:
    """``provider`` of ``provider/name``; for a bare name, its provider in the cost map, or
    None when the cost map does not know it."""
    if "/" in model:
        return model.split("/", 1)[0]
    entry = litellm_cost_map().get(model)
    provider = entry.get("litellm_provider") if isinstance(entry, dict) else None
    return provider if isinstance(provider, str) else None


def key_variables(model: str) -> tuple[str, ...] | None:
    """The environment variables that may hold `model`'s key (any one will do), for the
    common providers; None for the others."""
    provider = known_provider(model)
    return KEY_VARIABLES.get(provider) if provider else None
