"""`ModelPool`: model spec strings → clients, and the checks run before any episode starts."""

from __future__ import annotations

import os
from pathlib import Path

from .builtin import (
    BUILTIN_MODELS,
    GreedyClient,
    RandomClient,
    ReplayClient,
    ReplaySource,
    Script,
    ScriptedClient,
    is_builtin,
    split_spec,
)
from .cache import ResponseCache
from .errors import ModelConfigError
from .human import HUMAN, HumanClient, SeatDesk
from .inspect_client import InspectClient, check_inspect_eval
from .litellm_client import LiteLLMClient, import_litellm
from .openai_http import OPENAI_KEY_ENV, OPENAI_PREFIX, OpenAIHTTPClient, preload
from .protocol import ModelClient
from .providers import key_variables, known_provider
from .remote import RemoteClient
from .settings import ModelSettings, is_local_url

_BUILTIN_USAGE = "built-ins: greedy, random, random:SEED, scripted:FILE, replay:PATH, human"
_UNKNOWN_MODEL = (
    "unknown model: LiteLLM cannot tell its provider; write provider/model (e.g. "
    "openai/gpt-4o, anthropic/claude-sonnet-4-5, openai/NAME with --api-base for an "
    f"OpenAI-compatible server), or one of the {_BUILTIN_USAGE}"
)
_REMOTE_CLIENTS: dict[str, type[RemoteClient]] = {
    kind.transport: kind for kind in (LiteLLMClient, OpenAIHTTPClient, InspectClient)}


class ModelPool:
    """Makes the clients of a run from spec strings.

    Remote clients (LiteLLM, or the ``http`` transport) are shared per model string (one
    concurrency limit and one cache per model); built-in clients are made once per (spec,
    episode, agent), since they keep state.
    Files named by ``scripted:``/``replay:`` specs are read once per pool; ``human`` seats
    ask `desk`.
    """

    def __init__(self, settings: ModelSettings | None = None, *,
                 desk: SeatDesk | None = None) -> None:
        self.settings = settings if settings is not None else ModelSettings()
        self.desk = desk
        self.cache = (
            ResponseCache(self.settings.cache_dir) if self.settings.cache_dir is not None else None
        )
        self._remote: dict[str, RemoteClient] = {}
        self._builtin: dict[tuple[str, str, str | None], ModelClient] = {}
        self._scripts: dict[str, Script] = {}
        self._replays: dict[str, ReplaySource] = {}

    def client(self, spec: str, *, episode: str, agent: str | None) -> ModelClient:
        """The client answering for `agent` (None = centralized) in `episode`."""
        name, arg = split_spec(spec)
        if name not in BUILTIN_MODELS:
            remote = self._remote.get(spec)
            if remote is None:
                kind = _REMOTE_CLIENTS[self.settings.transport]
                remote = self._remote[spec] = kind(spec, self.settings, cache=self.cache)
            return remote
        key = (spec, episode, agent)
        client = self._builtin.get(key)
        if client is None:
            client = self._builtin[key] = self._make_builtin(spec, name, arg, episode, agent)
        return client

    async def aclose(self) -> None:
        """Close the connections remote clients keep open for the running event loop."""
        for remote in self._remote.values():
            await remote.aclose()

    def release(self, episode: str) -> None:
        """Forget the built-in clients of a finished episode."""
        for key in [k for k in self._builtin if k[1] == episode]:
            del self._builtin[key]

    def validate(self, spec: str) -> None:
        """Raise `ModelConfigError` (one line: the model and what to set or fix) unless
        `spec` can be used: built-in files readable, LiteLLM model known (an ``openai/`` one
        for the ``http`` transport), API key present."""
        name, arg = split_spec(spec)
        if name in BUILTIN_MODELS:
            self._builtin_source(spec, name, arg)
        else:
            self._validate_remote(spec)

    # -- built-ins --------------------------------------------------------------------------

    def _builtin_source(self, spec: str, name: str, arg: str | None) -> Script | ReplaySource | int:
        if name in ("greedy", HUMAN):
            if arg is not None:
                raise ModelConfigError(spec, f"{name} takes no argument ({_BUILTIN_USAGE})")
            return 0
        if name == "random":
            if arg is None:
                return self.settings.seed if self.settings.seed is not None else 0
            try:
                return int(arg)
            except ValueError:
                raise ModelConfigError(spec, "the seed must be an integer: random:SEED") from None
        if not arg:
            raise ModelConfigError(spec, f"{name} needs a path: {name}:PATH ({_BUILTIN_USAGE})")
        if name == "scripted":
            script = self._scripts.get(arg)
            if script is None:
                script = self._scripts[arg] = Script(Path(arg), spec)
            return script
        source = self._replays.get(arg)
        if source is None:
            source = ReplaySource(Path(arg), spec)
            source.check()
            self._replays[arg] = source
        return source

    def _make_builtin(
        self, spec: str, name: str, arg: str | None, episode: str, agent: str | None
    ) -> ModelClient:
        source = self._builtin_source(spec, name, arg)
        if name == "greedy":
            return GreedyClient(spec)
        if name == HUMAN:
            if self.desk is None:
                raise ModelConfigError(spec, "a human seat needs a player: run it with "
                                       "`cocobench run` (it serves a play page)")
            return HumanClient(self.desk, episode=episode, agent=agent)
        if name == "random":
            assert isinstance(source, int)
            return RandomClient(spec, seed=source, episode=episode, agent=agent)
        if name == "scripted":
            assert isinstance(source, Script)
            return ScriptedClient(spec, source.for_agent(agent))
        assert isinstance(source, ReplaySource)
        return ReplayClient(spec, source, episode=episode, agent=agent)

    # -- remote models ----------------------------------------------------------------------

    def _validate_remote(self, spec: str) -> None:
        s = self.settings
        if s.transport == "inspect":
            check_inspect_eval(spec)  # Inspect resolved the model and its key already
            return
        if s.transport == "http":
            self._validate_http_model(spec)
        elif known_provider(spec) is None:  # told from LiteLLM's cost map, without LiteLLM
            raise ModelConfigError(spec, _UNKNOWN_MODEL)
        if s.api_key_env:
            if not os.environ.get(s.api_key_env):
                raise ModelConfigError(
                    spec, f"no API key: the variable {s.api_key_env} (--api-key-env) is not set"
                )
        else:
            missing = self._missing_keys(spec)
            if missing:
                raise ModelConfigError(
                    spec,
                    f"no API key: set {' and '.join(missing)} in the environment or in a .env "
                    "file (or name the variable holding the key with --api-key-env)",
                )
        if s.transport == "litellm":
            self._validate_litellm_model(spec)

    def _missing_keys(self, spec: str) -> list[str]:
        """The provider's key variables that are not set (none when it cannot be told)."""
        variables = needed_key_variables(self.settings, spec)
        if variables is not None:  # told without importing LiteLLM
            return [] if not variables or any(os.environ.get(v) for v in variables) else [
                " or ".join(variables)]
        litellm = import_litellm()
        try:
            env = litellm.validate_environment(model=spec, api_base=self.settings.api_base)
            return list(env.get("missing_keys") or [])
        except Exception:  # noqa: BLE001 - a provider LiteLLM cannot check is not our error
            return []

    def _validate_http_model(self, spec: str) -> None:
        if not spec.startswith(OPENAI_PREFIX):
            raise ModelConfigError(
                spec,
                "the http transport speaks the OpenAI chat-completions API only: name the "
                f"model {OPENAI_PREFIX}NAME, or use --transport litellm for other providers",
            )
        preload(spec)

    def _validate_litellm_model(self, spec: str) -> None:
        # Also imports LiteLLM (seconds) before episodes start rather than during the first.
        litellm = import_litellm()
        try:
            litellm.get_llm_provider(model=spec, api_base=self.settings.api_base)
        except Exception:  # noqa: BLE001 - LiteLLM raises several types for an unknown model
            raise ModelConfigError(spec, _UNKNOWN_MODEL) from None


def needed_key_variables(settings: ModelSettings, model: str) -> tuple[str, ...] | None:
    """The environment variables `model`'s key is read from under `settings`, any one of
    which will do (names only): none for a built-in or for a local `api_base` without
    `api_key_env` (local servers rarely check keys); None when only LiteLLM can tell."""
    if (is_builtin(model) or settings.transport == "inspect"  # Inspect reads its keys
            or (is_local_url(settings.api_base) and not settings.api_key_env)):
        return ()
    if settings.api_key_env:
        return (settings.api_key_env,)
    if settings.transport == "http":
        return (OPENAI_KEY_ENV,)
    return key_variables(model)
