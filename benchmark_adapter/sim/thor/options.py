"""`ThorOptions`: how to run AI2-THOR. The scene and the agents come from the task config."""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

PLATFORMS = ("auto", "CloudRendering", "Linux64", "OSXIntel64")
MIN_SIZE = 300  # the reference never renders below 300×300 (reference §1, env.py)
ENV_PREFIX = "COCOBENCH_THOR_"
# Environment variables that set options, so a GPU box is configured once, not per command.
ENV_FIELDS = {
    "PLATFORM": "platform",
    "WIDTH": "width",
    "HEIGHT": "height",
    "QUALITY": "quality",
    "GPU_DEVICE": "gpu_device",
    "X_DISPLAY": "x_display",
    "BUILD": "local_executable_path",
    "LOOKUP_TIMEOUT": "lookup_timeout",
    "DOWNLOAD_TIMEOUT": "download_timeout",
}


@dataclass(frozen=True)
class ThorOptions:
    """Run options of the AI2-THOR backend.

    `platform="auto"` picks CloudRendering when Vulkan is present, else Linux64 when an X
    display is. `local_executable_path` runs a build you unpacked yourself; `local_build` uses
    ai2thor's own source-checkout build folder. The timeouts (seconds) bound the build lookup,
    its download, one reply from Unity and Unity's start.
    """

    platform: str = "auto"
    width: int = MIN_SIZE
    height: int = MIN_SIZE
    quality: str = "Low"
    gpu_device: int | None = None
    x_display: str | None = None
    local_executable_path: str | None = None
    local_build: bool = False
    lookup_timeout: float = 60.0
    download_timeout: float = 1800.0
    server_timeout: float = 100.0
    start_timeout: float = 300.0
    reuse: bool = True

    def __post_init__(self) -> None:
        if self.platform not in PLATFORMS:
            raise ValueError(
                f"platform must be one of {', '.join(PLATFORMS)}, not {self.platform!r}"
            )
        # Frozen: normalise through object.__setattr__.
        object.__setattr__(self, "width", max(int(self.width), MIN_SIZE))
        object.__setattr__(self, "height", max(int(self.height), MIN_SIZE))
        for name in ("lookup_timeout", "download_timeout", "server_timeout", "start_timeout"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0 seconds")

    @classmethod
    def from_options(cls, options: Mapping[str, Any]) -> ThorOptions:
        """Options from keyword arguments; an unknown name is a clear error, not a TypeError."""
        known = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(options) - known)
        if unknown:
            raise ValueError(
                f"unknown ai2thor backend option(s): {', '.join(unknown)} "
                f"(known: {', '.join(sorted(known))})"
            )
        return cls(**options)

    @classmethod
    def from_env(cls, environ: Mapping[str, str] | None = None, **overrides: Any) -> ThorOptions:
        """Options from `COCOBENCH_THOR_*` variables, then `overrides` (which win)."""
        environ = os.environ if environ is None else environ
        types = {f.name: f.type for f in dataclasses.fields(cls)}
        values: dict[str, Any] = {}
        for suffix, name in ENV_FIELDS.items():
            raw = environ.get(ENV_PREFIX + suffix)
            if raw:
                values[name] = _parse(raw, str(types[name]), ENV_PREFIX + suffix)
        values.update({k: v for k, v in overrides.items() if v is not None})
        return cls.from_options(values)

    def pool_key(self) -> tuple[Any, ...]:
        """What a running Unity process is tied to; episodes with equal keys share one."""
        return (
            self.platform,
            self.width,
            self.height,
            self.quality,
            self.gpu_device,
            self.x_display,
            self.local_executable_path,
            self.local_build,
        )


def _parse(raw: str, type_name: str, variable: str) -> Any:
    try:
        if type_name.startswith("int"):
            return int(raw)
        if type_name.startswith("float"):
            return float(raw)
    except ValueError as exc:
        raise ValueError(f"{variable}={raw!r} is not a number") from exc
    return raw
