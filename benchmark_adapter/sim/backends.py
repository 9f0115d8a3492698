"""The simulator backends by name: `make_controller(config, backend, **options)`.

`embedded` (default) is the in-process symbolic world; `ai2thor` is real AI2-THOR 5.0 (needs
the `thor` extra and a GPU or an X display). Both speak the `Controller` protocol.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Mapping
from typing import Any

from benchmark_adapter.sim.protocol import Controller
from benchmark_adapter.tasks.config import TaskConfig
from benchmark_adapter.vocabulary import AI2THOR, DEFAULT_BACKEND, EMBEDDED


def _embedded(config: TaskConfig, **options: Any) -> Controller:
    _no_options(EMBEDDED, options)
    from benchmark_adapter.sim.embedded import EmbeddedController

    return EmbeddedController(config)


def _ai2thor(config: TaskConfig, **options: Any) -> Controller:
    from benchmark_adapter.sim.thor import ThorController, ThorOptions

    return ThorController(config, ThorOptions.from_env(**options))


BACKENDS: dict[str, Callable[..., Controller]] = {
    EMBEDDED: _embedded,
    AI2THOR: _ai2thor,
}
"""Backend name → `factory(config, **options)`."""


def make_controller(
    config: TaskConfig, backend: str = DEFAULT_BACKEND, **options: Any
) -> Controller:
    """A controller for `config` on the named backend.

    `ai2thor` options are `ThorOptions` fields (platform, width, height, quality, gpu_device,
    x_display, local_executable_path, …); unset ones come from `COCOBENCH_THOR_*` variables.
    """
    return _factory_for(backend)(config, **options)


def controller_factory(
    backend: str = DEFAULT_BACKEND, **options: Any
) -> Callable[[TaskConfig], Controller]:
    """A picklable `config → controller` for worker processes; checks name and options now,
    so a typo fails before the first episode rather than in every worker."""
    _factory_for(backend)
    if backend == AI2THOR:
        from benchmark_adapter.sim.thor import ThorOptions

        ThorOptions.from_env(**options)
    else:
        _no_options(backend, options)
    return functools.partial(make_controller, backend=backend, **options)


def check_backend(backend: str = DEFAULT_BACKEND, **options: Any) -> None:
    """Everything that can be checked before the first episode, without starting anything:
    the name, the options and, for `ai2thor`, the package and a renderer (raises
    `ThorUnavailable` with the remedy). Call it once at the start of a command."""
    controller_factory(backend, **options)
    if backend == AI2THOR:
        from benchmark_adapter.sim.thor import ThorOptions, preflight
        from benchmark_adapter.sim.thor.loader import require_ai2thor

        require_ai2thor()
        preflight(ThorOptions.from_env(**options))


def _factory_for(backend: str) -> Callable[..., Controller]:
    try:
        return BACKENDS[backend]
    except KeyError:
        raise ValueError(
            f"unknown backend {backend!r}; choose one of: {', '.join(sorted(BACKENDS))}"
        ) from None


def _no_options(backend: str, options: Mapping[str, Any]) -> None:
    if options:
        raise ValueError(
            f"the {backend} backend takes no options (got: {', '.join(sorted(options))})"
        )
