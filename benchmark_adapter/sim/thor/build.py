"""Obtaining an AI2-THOR build without ever hanging.

ai2thor looks its build up with `requests.head` and downloads it with `requests.get`, both
without a timeout: on a machine whose firewall silently drops packets, `Controller()` blocks
forever. `BuildGuard` runs the lookup and the download in a worker thread and gives up after
a deadline we control, with a message saying how to use a pre-downloaded build instead.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, TypeVar

from benchmark_adapter.sim.thor.errors import PRE_DOWNLOADED, RENDERING, ThorUnavailable

T = TypeVar("T")


class DeadlineExceeded(TimeoutError):
    """A guarded call did not finish in time (its thread is left to finish on its own)."""


def within(seconds: float, what: str, fn: Callable[[], T]) -> T:
    """Run `fn()` in a daemon thread; its result, its exception, or `DeadlineExceeded`."""
    outcome: dict[str, Any] = {}

    def target() -> None:
        try:
            outcome["value"] = fn()
        except BaseException as exc:  # noqa: BLE001 - handed to the caller's thread below
            outcome["error"] = exc

    # Daemon: a lookup stuck in a socket read must not keep the interpreter alive at exit.
    worker = threading.Thread(target=target, name=f"ai2thor: {what}", daemon=True)
    worker.start()
    worker.join(seconds)
    if worker.is_alive():
        raise DeadlineExceeded(f"{what} did not finish within {seconds:g} s")
    if "error" in outcome:
        raise outcome["error"]
    return outcome["value"]


class LocalBuild:
    """A build the user unpacked, launched as the chosen platform.

    ai2thor's own `ExternalBuild` (its `local_executable_path`) always launches as Linux64,
    which needs an X display even for a CloudRendering build; this one keeps the platform.
    It offers the attributes ai2thor's `Controller` reads from a build.
    """

    server_types = ("FIFO", "WSGI")
    url = None

    def __init__(self, executable_path: str, platform: Any) -> None:
        self.executable_path = os.path.expanduser(executable_path)
        self.platform = platform

    def download(self) -> None:
        """Nothing to download."""

    def lock_sh(self) -> None:
        """Nothing to lock: ai2thor only locks builds in its own cache."""

    def unlock(self) -> None:
        """Nothing to unlock."""


@dataclass(frozen=True)
class BuildGuard:
    """How ai2thor's `find_build` is run: under deadlines, or replaced by a local build."""

    lookup_timeout: float
    download_timeout: float
    local_executable_path: str | None = None

    def obtain(self, find: Callable[..., Any], *args: Any) -> Any:
        """The build `find(*args)` (ai2thor's `find_build`) picks, downloaded, or a clear error."""
        if self.local_executable_path:
            return LocalBuild(self.local_executable_path, args[-1])
        build = self._guarded(self.lookup_timeout, "looking up the AI2-THOR build", find, *args)
        self._guarded(self.download_timeout, f"downloading {build.name}", build.download)
        return build

    def _guarded(self, seconds: float, what: str, fn: Callable[..., T], *args: Any) -> T:
        try:
            return within(seconds, what, lambda: fn(*args))
        except DeadlineExceeded as exc:
            raise ThorUnavailable(
                f"{exc} (no answer from the AI2-THOR build server: offline, or behind a proxy "
                "or firewall?)",
                f"{PRE_DOWNLOADED}; or raise the limit with COCOBENCH_THOR_LOOKUP_TIMEOUT / "
                "COCOBENCH_THOR_DOWNLOAD_TIMEOUT (seconds)",
            ) from exc
        except ThorUnavailable:
            raise
        except Exception as exc:
            raise _no_build(what, exc) from exc


def _no_build(what: str, exc: Exception) -> ThorUnavailable:
    text = str(exc)
    if "missing dependencies" in text:  # a build exists, but its platform cannot run here
        return ThorUnavailable(f"{what} failed: {text}", RENDERING)
    return ThorUnavailable(
        f"{what} failed: no AI2-THOR build could be obtained ({text})", PRE_DOWNLOADED
    )
