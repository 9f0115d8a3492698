"""The one place that imports ai2thor, on first use only (importing `benchmark_adapter` never
does: ai2thor pulls in requests, opencv's Python deps and Xlib)."""

from __future__ import annotations

import importlib
from types import ModuleType

from benchmark_adapter.sim.thor.errors import INSTALL, ThorUnavailable, not_installed, wrong_version

SUPPORTED_MAJOR = "5."


def require_ai2thor() -> ModuleType:
    """The `ai2thor` package with its controller loaded; raises `ThorUnavailable` if missing."""
    try:
        ai2thor = importlib.import_module("ai2thor")
    except ImportError as exc:
        raise not_installed() from exc
    try:
        for module in ("ai2thor.controller", "ai2thor.server", "ai2thor.platform"):
            importlib.import_module(module)
    except ImportError as exc:  # installed, but one of its own dependencies is broken
        raise ThorUnavailable(
            f"ai2thor is installed but cannot be imported ({exc})", f"reinstall it: {INSTALL}"
        ) from exc
    version = getattr(ai2thor, "__version__", None)
    if not (version or "").startswith(SUPPORTED_MAJOR):
        raise wrong_version(version)
    return ai2thor

