"""Counting prompt tokens and pricing them, offline: the token counter LiteLLM picks for each
model (never one it would download), and the prices of the cost map LiteLLM ships."""

from __future__ import annotations

from types import ModuleType
from typing import Any

from cocobench_agents.models import is_builtin

#: LiteLLM's Hugging Face tokenizers that it downloads from the Hub on first use (the
#: Anthropic and DeepSeek ones ship with it). A dry run fetches nothing, so models that would
#: use these are counted with tiktoken instead, and their counter says so.
_HUB_TOKENIZERS = {"llama2": "hf-internal-testing/llama-tokenizer",
                   "llama3": "Xenova/llama-3-tokenizer",
                   "cohere": "Xenova/c4ai-command-r-v01-tokenizer"}
#: Providers whose models' own tokenizers tiktoken has (named "the model's own").
_OPENAI_PROVIDERS = ("openai", "azure", "text-completion-openai")


class TokenCounter:
    """LiteLLM's token counter for one model, its tokenizer chosen once and named."""

    def __init__(self, litellm: ModuleType, model: str) -> None:
        self._litellm, self.model = litellm, model
        self._counted: dict[tuple[str, tuple[str, ...]], int] = {}
        self.tokenizer, self.description = _tokenizer(litellm, model)

    def count(self, messages: list[dict[str, Any]]) -> int:
        if not messages:
            return 0
        key = _messages_key(messages)
        tokens = self._counted.get(key)
        if tokens is None:
            tokens = self._counted[key] = int(self._litellm.token_counter(
                model="" if is_builtin(self.model) else self.model,
                custom_tokenizer=self.tokenizer, messages=messages))
        return tokens


def _messages_key(messages: list[dict[str, Any]]) -> tuple[str, tuple[str, ...]]:
    """A hashable key of one user message: its text and image URLs."""
    content = messages[0]["content"]
    if isinstance(content, str):
        return content, ()
    return content[0]["text"], tuple(part["image_url"]["url"] for part in content[1:])


def _tokenizer(litellm: ModuleType, model: str) -> tuple[dict[str, Any], str]:
    """The tokenizer LiteLLM's `token_counter` picks for `model`, and what it is.

    Built-in models are counted as LiteLLM counts a model it knows nothing about. Tokenizers
    LiteLLM would download are not: tiktoken, as LiteLLM's own fallback, stands in."""
    from litellm.litellm_core_utils.token_counter import openai_tokenizer_encoding_name
    from litellm.utils import huggingface_tokenizer_kind, select_tokenizer

    name = "" if is_builtin(model) else model
    encoding = openai_tokenizer_encoding_name(name)
    kind = huggingface_tokenizer_kind(name)
    if kind in _HUB_TOKENIZERS:
        # LiteLLM's tiktoken tokenizer; `token_counter` picks the encoding by the model's name.
        return select_tokenizer(""), (
            f"tiktoken {encoding} (LiteLLM would download {_HUB_TOKENIZERS[kind]} from the "
            "Hugging Face Hub; a dry run fetches nothing)")
    selected = select_tokenizer(name)
    if selected["type"] == "huggingface_tokenizer":
        return selected, f"Hugging Face {kind} tokenizer (bundled with LiteLLM)"
    if kind is not None:
        return selected, (f"tiktoken {encoding} (LiteLLM's fallback: its {kind} tokenizer "
                          "could not be loaded)")
    if is_builtin(model):
        return selected, f"tiktoken {encoding} (LiteLLM's default; a built-in model is free)"
    if _provider(litellm, name) in _OPENAI_PROVIDERS:
        return selected, f"tiktoken {encoding} (the model's own, via LiteLLM)"
    return selected, f"tiktoken {encoding} (LiteLLM's default: it has no tokenizer of this model)"


def _provider(litellm: ModuleType, model: str) -> str | None:
    """The provider the cost map lists `model` under, or None when it does not list it."""
    try:
        return litellm.get_model_info(model=model).get("litellm_provider")
    except Exception:  # noqa: BLE001 - LiteLLM raises several types for an unmapped model
        return None


def price_per_token(litellm: ModuleType, model: str) -> tuple[float, float] | None:
    """USD per (input, output) token: 0 for built-ins (they call nothing), the cost map's for
    a model it prices, None for one it does not."""
    if is_builtin(model):
        return 0.0, 0.0
    try:
        info = litellm.get_model_info(model=model)
    except Exception:  # noqa: BLE001 - LiteLLM raises several types for an unmapped model
        return None
    price_in, price_out = info.get("input_cost_per_token"), info.get("output_cost_per_token")
    if price_in is None or price_out is None:
        return None
    return float(price_in), float(price_out)
