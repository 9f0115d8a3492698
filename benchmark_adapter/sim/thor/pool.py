"""One running AI2-THOR per worker process, reused across the episodes it runs.

Starting Unity takes seconds and a scene reset a fraction of that, so a `ThorController`
leases a started ai2thor controller from the process-wide `POOL` and gives it back on
`stop()`; the next episode with the same run options reconfigures it with a reset (new scene,
new agentCount). Sessions are shut down at interpreter exit (atexit; multiprocessing workers'
exit finalizers; SIGTERM turned into a normal exit), on Ctrl-C, and whenever a call into Unity
fails.
"""

from __future__ import annotations

import atexit
import logging
import multiprocessing.util
import os
import signal
import threading
import weakref
from collections.abc import Callable, Hashable
from dataclasses import dataclass
from typing import Any

log = logging.getLogger(__name__)


@dataclass(eq=False)
class Session:
    """A started ai2thor controller and the `ThorController` currently using it."""

    key: Hashable
    controller: Any
    holder: weakref.ref | None = None
    uses: int = 0  # leases so far; more than one means reconfigured by a reset

    def free(self) -> bool:
        """Nobody holds it (a holder that was garbage-collected without `stop()` counts)."""
        return self.holder is None or self.holder() is None


def shutdown(controller: Any) -> None:
    """Stop an ai2thor controller and its Unity process; never leaves Unity running.

    Errors while stopping are logged, not raised (we are usually already unwinding); a second
    Ctrl-C during the stop kills Unity and is then re-raised.
    """
    try:
        controller.stop()
    except KeyboardInterrupt:
        _kill(controller)
        raise
    except Exception:
        log.warning("stopping AI2-THOR failed; killing its process", exc_info=True)
        _kill(controller)


def _kill(controller: Any) -> None:
    proc = getattr(getattr(controller, "server", None), "unity_proc", None)
    if proc is not None and proc.poll() is None:
        proc.kill()


class ControllerPool:
    """Started ai2thor controllers of this process, keyed by their run options."""

    def __init__(self, install_exit_hooks: bool = True) -> None:
        self._sessions: list[Session] = []
        # Re-entrant: stop() may run in a signal handler while this thread holds the lock.
        self._lock = threading.RLock()
        self._pid = os.getpid()
        self._install_exit_hooks = install_exit_hooks
        self._hooked = False

    def __len__(self) -> int:
        self._forget_after_fork()
        return len(self._sessions)

    def acquire(self, key: Hashable, owner: object, create: Callable[[], Any]) -> Session:
        """A free session for `key` leased to `owner`, started with `create()` if none is free."""
        self._forget_after_fork()
        with self._lock:
            for session in self._sessions:
                if session.key == key and session.free():
                    session.holder = weakref.ref(owner)
                    session.uses += 1
                    return session
        controller = create()  # outside the lock: starting Unity takes seconds
        session = Session(key, controller, weakref.ref(owner), uses=1)
        with self._lock:
            self._sessions.append(session)
        self._hook_exit()
        return session

    def release(self, session: Session, owner: object) -> None:
        """Give a session back for the next episode (a no-op unless `owner` holds it)."""
        if session.holder is not None and session.holder() is owner:
            session.holder = None

    def discard(self, session: Session) -> None:
        """Remove a session and shut its Unity down."""
        with self._lock:
            if session in self._sessions:
                self._sessions.remove(session)
        shutdown(session.controller)

    def close(self) -> None:
        """Shut every session down (registered with atexit)."""
        self._forget_after_fork()
        with self._lock:
            sessions, self._sessions = self._sessions, []
        for session in sessions:
            shutdown(session.controller)

    def _forget_after_fork(self) -> None:
        # A forked worker inherits the parent's sessions, whose pipes belong to the parent.
        if os.getpid() != self._pid:
            self._sessions, self._pid, self._hooked = [], os.getpid(), False

    def _hook_exit(self) -> None:
        if self._hooked or not self._install_exit_hooks:
            return
        self._hooked = True
        atexit.register(self.close)
        # multiprocessing workers leave through os._exit, skipping atexit, but run these.
        multiprocessing.util.Finalize(None, self.close, exitpriority=10)
        install_sigterm_exit()


def install_sigterm_exit() -> bool:
    """Make SIGTERM a normal exit (so atexit stops Unity) unless someone handles it already."""
    if threading.current_thread() is not threading.main_thread():
        return False
    if signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL:
        return False
    signal.signal(signal.SIGTERM, _exit_on_sigterm)
    return True


def _exit_on_sigterm(signum: int, frame: Any) -> None:
    raise SystemExit(128 + signum)


POOL = ControllerPool()
"""The process-wide pool used by default."""
