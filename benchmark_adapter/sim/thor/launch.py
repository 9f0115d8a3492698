"""Starting AI2-THOR: preflight checks, a guarded build lookup, then ai2thor's `Controller`.

`open_controller` is the production factory of `ThorController`; tests pass their own
factory (ai2thor's `Controller` over a fake server) and reuse `controller_kwargs`, so the
arguments given to ai2thor are the same in both.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from typing import Any, Protocol

from benchmark_adapter.sim.thor.build import BuildGuard
from benchmark_adapter.sim.thor.environment import preflight
from benchmark_adapter.sim.thor.errors import RENDERING, ThorUnavailable
from benchmark_adapter.sim.thor.loader import require_ai2thor
from benchmark_adapter.sim.thor.options import ThorOptions

START_REMEDY = (
    "read Unity's log (~/.ai2thor/log/unity.log and ~/.config/unity3d/Allen Institute for "
    f"Artificial Intelligence/AI2-THOR/Player.log); {RENDERING}"
)


class ControllerFactory(Protocol):
    """Builds a started ai2thor `Controller` with `scene` loaded and `init` applied."""

    def __call__(self, options: ThorOptions, scene: str, init: Mapping[str, Any]) -> Any: ...


def controller_kwargs(
    options: ThorOptions, scene: str, init: Mapping[str, Any], platform: str
) -> dict[str, Any]:
    """Keyword arguments of ai2thor's `Controller` (its unknown keys go to `Initialize`)."""
    import ai2thor.platform

    kwargs: dict[str, Any] = {
        "scene": scene,
        "width": options.width,
        "height": options.height,
        "quality": options.quality,
        "platform": ai2thor.platform.STR_PLATFORM_MAP[platform],
        "local_build": options.local_build,
        "server_timeout": options.server_timeout,
        "server_start_timeout": options.start_timeout,
        **init,
    }
    if options.x_display:
        kwargs["x_display"] = options.x_display
    if platform == "CloudRendering" and options.gpu_device is not None:
        kwargs["gpu_device"] = options.gpu_device
    return kwargs


@functools.cache
def guarded_controller_class() -> type:
    """ai2thor's `Controller`, with its build lookup run by a `BuildGuard` (defined lazily:
    subclassing needs the import)."""
    base = require_ai2thor().controller.Controller

    class GuardedController(base):  # type: ignore[misc,valid-type]
        """ai2thor's `Controller` whose build lookup and download cannot hang."""

        def __init__(self, *, guard: BuildGuard, **kwargs: Any) -> None:
            # Set before the base __init__, which calls find_build.
            self._guard = guard
            super().__init__(**kwargs)

        def find_build(self, local_build: Any, commit_id: Any, branch: Any, platform: Any) -> Any:
            return self._guard.obtain(super().find_build, local_build, commit_id, branch, platform)

    return GuardedController


def open_controller(options: ThorOptions, scene: str, init: Mapping[str, Any]) -> Any:
    """Start AI2-THOR for one scene; every way it can fail is a `ThorUnavailable`."""
    require_ai2thor()
    platform = preflight(options)
    guard = BuildGuard(
        options.lookup_timeout, options.download_timeout, options.local_executable_path
    )
    cls = guarded_controller_class()
    try:
        return cls(guard=guard, **controller_kwargs(options, scene, init, platform))
    except ThorUnavailable:
        raise
    except Exception as exc:
        raise ThorUnavailable(f"AI2-THOR did not start on {platform}: {exc}", START_REMEDY) from exc
