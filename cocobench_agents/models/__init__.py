"""Model clients: the `ModelClient` protocol, the remote clients (LiteLLM, and the lean
OpenAI-compatible ``http`` transport), offline built-ins, and the
`ModelPool` that makes them from spec strings. Importing this package does not import LiteLLM
(that happens on first use)."""

from .builtin import (
    BUILTIN_MODELS,
    GREEDY_SKILL_ORDER,
    GreedyClient,
    RandomClient,
    Script,
    ScriptedClient,
    greedy_choice,
    is_builtin,
    split_spec,
)
from .cache import ResponseCache, cache_key
from .errors import ModelConfigError
from .grammar import menu_grammar, wants_message
from .litellm_client import LiteLLMClient, import_litellm
from .messages import build_messages, cap_reply, image_data_url
from .openai_http import OpenAIHTTPClient
from .protocol import MenuOption, ModelClient, ModelError, ModelReply, ModelRequest
from .registry import ModelPool
from .remote import Completion, RemoteClient
from .replay import ReplayClient, ReplaySource, recorded_replies
from .retry import RetryPolicy
from .secrets import REDACTED, redact, redact_obj
from .settings import (
    LOCAL_PLACEHOLDER_KEY,
    TEMPERATURE_AUTO,
    TRANSPORTS,
    ModelSettings,
    is_local_url,
)

__all__ = [
    "BUILTIN_MODELS",
    "GREEDY_SKILL_ORDER",
    "LOCAL_PLACEHOLDER_KEY",
    "REDACTED",
    "TEMPERATURE_AUTO",
    "TRANSPORTS",
    "Completion",
    "GreedyClient",
    "LiteLLMClient",
    "MenuOption",
    "ModelClient",
    "ModelConfigError",
    "ModelError",
    "ModelPool",
    "ModelReply",
    "ModelRequest",
    "ModelSettings",
    "OpenAIHTTPClient",
    "RandomClient",
    "RemoteClient",
    "ReplayClient",
    "ReplaySource",
    "ResponseCache",
    "RetryPolicy",
    "Script",
    "ScriptedClient",
    "build_messages",
    "cache_key",
    "cap_reply",
    "greedy_choice",
    "image_data_url",
    "import_litellm",
    "is_builtin",
    "is_local_url",
    "menu_grammar",
    "recorded_replies",
    "redact",
    "redact_obj",
    "split_spec",
    "wants_message",
]
