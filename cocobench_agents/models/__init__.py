"""Model clients: the `ModelClient` protocol, the remote clients (LiteLLM, and the lean
OpenAI-compatible ``http`` transport), offline built-ins, and the
`ModelPool` that makes them from spec strings. Importing this package does not import LiteLLM
(that happens on first use).

Names load on first use (PEP 562): a module that needs one name (the run request needs
`ModelSettings`) does not pay for every client.
"""

from __future__ import annotations

from cocobench_agents.lazy import lazy_getattr

_EXPORTS = {
    "BUILTIN_MODELS": ".builtin",
    "GREEDY_SKILL_ORDER": ".builtin",
    "GreedyClient": ".builtin",
    "RandomClient": ".builtin",
    "Script": ".builtin",
    "ScriptedClient": ".builtin",
    "greedy_choice": ".builtin",
    "is_builtin": ".builtin",
    "split_spec": ".builtin",
    "ResponseCache": ".cache",
    "cache_key": ".cache",
    "ModelConfigError": ".errors",
    "menu_grammar": ".grammar",
    "wants_message": ".grammar",
    "LiteLLMClient": ".litellm_client",
    "import_litellm": ".litellm_client",
    "build_messages": ".messages",
    "cap_reply": ".messages",
    "image_data_url": ".messages",
    "OpenAIHTTPClient": ".openai_http",
    "MenuOption": ".protocol",
    "ModelClient": ".protocol",
    "ModelError": ".protocol",
    "ModelReply": ".protocol",
    "ModelRequest": ".protocol",
    "ModelPool": ".pool",
    "Completion": ".remote",
    "RemoteClient": ".remote",
    "ReplayClient": ".replay",
    "ReplaySource": ".replay",
    "recorded_replies": ".replay",
    "RetryPolicy": ".retry",
    "REDACTED": ".secrets",
    "redact": ".secrets",
    "redact_obj": ".secrets",
    "LOCAL_PLACEHOLDER_KEY": ".settings",
    "ModelSettings": ".settings",
    "TEMPERATURE_AUTO": ".settings",
    "TRANSPORTS": ".settings",
    "ENDPOINT_TRANSPORTS": ".settings",
    "is_local_url": ".settings",
}
__all__ = sorted(_EXPORTS)

__getattr__ = lazy_getattr(__name__, _EXPORTS)
