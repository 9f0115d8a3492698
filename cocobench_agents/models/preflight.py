"""Pre-flight: one cheap call per remote model and input kind before any episode starts.

The model name, the key, the endpoint and the request settings are only really checked by
the provider. Without this, an unknown model, a dead endpoint or a text-only model asked
with images would fail every call of every episode, and the run would record each one as an
episode of a weak model. Built-in models need no check; the response cache is bypassed (a
cached answer proves nothing about the endpoint).
"""

from __future__ import annotations

import asyncio
import functools
import io
from collections.abc import Iterable

from benchmark_adapter.vocabulary import IMAGE

from .builtin import is_builtin
from .pool import ModelPool
from .protocol import MenuOption, ModelError, ModelRequest
from .secrets import redact
from .settings import ModelSettings

PROBE_PROMPT = "This is a connection check. Reply exactly:\nREASON: ok\nACTION: 1"
PROBE_MENU = (MenuOption(1, "Wait", "Wait()"),)  # for --grammar, which builds on the menu
#: The probe's own completion cap (the run's when smaller): any answer passes, and a small
#: local model left uncapped generated for minutes inside the pre-flight.
PROBE_MAX_TOKENS = 16


class PreflightError(ValueError):
    """A model that failed its pre-flight call: the provider's message, one line per model
    and input kind (a user error: exit code 2)."""


def preflight(pool: ModelPool, models: Iterable[str], obs_modes: Iterable[str]) -> None:
    """Send one call per remote model in `models` and observation mode in `obs_modes` (an
    ``image`` mode sends a tiny image too) with the run's settings; raise `PreflightError`
    naming every model whose call failed. Nothing is written anywhere."""
    with_images = sorted({mode == IMAGE for mode in obs_modes})
    checks = [(model, images) for model in dict.fromkeys(models) if not is_builtin(model)
              for images in with_images]
    if not checks:
        return
    failures = [f for f in asyncio.run(_probe_all(pool, checks)) if f]
    if failures:
        raise PreflightError(
            "pre-flight call failed (no episode was started; --no-preflight skips this "
            "check): " + " | ".join(failures))


async def _probe_all(pool: ModelPool, checks: list[tuple[str, bool]]) -> list[str | None]:
    probes = ModelPool(probe_settings(pool.settings))
    try:
        return await asyncio.gather(*(_probe(probes, model, images) for model, images in checks))
    finally:
        await probes.aclose()


def probe_settings(settings: ModelSettings) -> ModelSettings:
    """The run's settings as the probe sends them: no cache (a cached answer proves nothing
    about the endpoint), at most `PROBE_MAX_TOKENS` completion tokens."""
    cap = min(settings.max_tokens or PROBE_MAX_TOKENS, PROBE_MAX_TOKENS)
    return settings.model_copy(update={"cache_dir": None, "max_tokens": cap})


def probe_request(images: bool) -> ModelRequest:
    """The probe: the connection-check prompt, with a tiny image when `images`."""
    return ModelRequest(prompt=PROBE_PROMPT, images=(tiny_png(),) if images else (),
                        menu=PROBE_MENU)


async def _probe(pool: ModelPool, model: str, images: bool) -> str | None:
    """None when `model` answered, else what went wrong."""
    client = pool.client(model, episode="preflight", agent=None)
    try:
        await client.complete(probe_request(images))
    except ModelError as error:
        if error.kind == "empty":  # the provider answered: what matters here is that it can
            return None
        what = "with an image" if images else "text only"
        return redact(f"{model} ({what}): {error}", [pool.settings.api_key()])
    return None


@functools.cache
def tiny_png() -> bytes:
    """An 8×8 grey PNG: the smallest image any vision model takes."""
    from PIL import Image

    buffer = io.BytesIO()
    Image.new("RGB", (8, 8), (128, 128, 128)).save(buffer, format="PNG")
    return buffer.getvalue()
