"""A local Ray for one run that leaves no process behind, even when the run is SIGKILLed.

`ray.init()` in the driver starts Ray's processes as the driver's children; most die with
it, but Ray's agents (children of the raylet) outlive a killed driver for a minute or more.
So the driver does not start Ray itself: it starts a keeper, ``python -m
cocobench_agents.harness.ray_local``, in its own session (the terminal's Ctrl-C goes to the
driver only). The keeper makes itself a child subreaper (Linux), starts Ray, prints the
address, and waits for its stdin to close, which happens when the driver leaves however it
leaves. Then it shuts Ray down and kills whatever descended from it and is still alive
(orphans are re-parented to a subreaper, so nothing escapes the sweep).
"""

from __future__ import annotations

import argparse
import contextlib
import ctypes
import functools
import logging
import os
import secrets
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass

from cocobench_agents.harness.errors import WorkerError

PR_SET_CHILD_SUBREAPER = 36
START_TIMEOUT_S = 120.0
STOP_TIMEOUT_S = 30.0


class LocalRayError(WorkerError):
    """The local Ray could not be started."""


@dataclass(frozen=True)
class LocalRay:
    """A running keeper, the address of its Ray and the variables a driver needs to join it
    (its private authentication token)."""

    address: str
    keeper: subprocess.Popen
    auth_env: dict[str, str]

    def stop(self) -> None:
        """Close the keeper's stdin (it then stops Ray) and wait for it to finish."""
        with contextlib.suppress(OSError):
            self.keeper.stdin.close()  # type: ignore[union-attr]
        try:
            self.keeper.wait(timeout=STOP_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            self.keeper.kill()
            self.keeper.wait()


@contextlib.contextmanager
def local_ray(num_cpus: int, num_gpus: float | None = None) -> Iterator[LocalRay]:
    """A private local Ray with `num_cpus` (and `num_gpus`, default: those Ray detects)
    logical resources, stopped with every process it started when the block is left."""
    command = [sys.executable, "-m", __name__, "--num-cpus", str(num_cpus)]
    if num_gpus is not None:
        command += ["--num-gpus", str(num_gpus)]
    auth_env = {"RAY_AUTH_MODE": "token", "RAY_AUTH_TOKEN": driver_token()}
    keeper = subprocess.Popen(command, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True, start_new_session=True,
                              env={**os.environ, **auth_env})
    session = LocalRay(_read_address(keeper), keeper, auth_env)
    try:
        yield session
    finally:
        session.stop()


@functools.cache
def driver_token() -> str:
    """This driver process's Ray authentication token: one per process, as Ray's token loader
    keeps the first it reads (a cluster this process starts itself, in tests or benchmarks,
    must use it too)."""
    # Fresh, and passed in the environment: Ray would otherwise write one to ~/.ray, and
    # anyone on the network could submit work to an unauthenticated Ray.
    return secrets.token_hex(32)


def _read_address(keeper: subprocess.Popen) -> str:
    assert keeper.stdout is not None and keeper.stderr is not None
    line = keeper.stdout.readline().strip()  # the keeper prints one line once Ray is up
    if line.startswith("address="):
        keeper.stderr.close()  # the keeper has silenced its stderr by now
        return line.removeprefix("address=")
    keeper.kill()
    detail = keeper.stderr.read().strip().splitlines()
    keeper.wait()
    raise LocalRayError("could not start a local Ray: "
                        + (detail[-1] if detail else f"keeper exit code {keeper.returncode}"))


# -- the keeper process ---------------------------------------------------------------------

def main(argv: list[str] | None = None) -> None:
    """Start Ray, print ``address=HOST:PORT``, stop it all when stdin closes."""
    parser = argparse.ArgumentParser(prog=f"python -m {__name__}")
    parser.add_argument("--num-cpus", type=int, required=True)
    parser.add_argument("--num-gpus", type=float, default=None)
    args = parser.parse_args(argv)
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # only the driver decides when to stop
    signal.signal(signal.SIGTERM, _exit_on_sigterm)
    _become_subreaper()
    import ray

    # address="local": a Ray of its own, never the one RAY_ADDRESS or /tmp/ray's record of
    # the last cluster started on this machine names (a user's `ray start`, a test's cluster).
    context = ray.init(address="local", num_cpus=args.num_cpus, num_gpus=args.num_gpus,
                       include_dashboard=False,
                       log_to_driver=False,
                       logging_level=logging.ERROR)
    try:
        print(f"address={context.address_info['gcs_address']}", flush=True)
        _silence_stderr()
        sys.stdin.read()  # returns at EOF: the driver has ended or let go
    finally:
        ray.shutdown()
        sweep_descendants()


def _exit_on_sigterm(signum: int, frame: object) -> None:
    raise SystemExit(128 + signum)


def _become_subreaper() -> None:
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL(None, use_errno=True).prctl(PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0)


def _silence_stderr() -> None:
    # The driver stops reading once it has the address; Ray's shutdown messages go nowhere.
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 2)
    os.close(devnull)


def sweep_descendants(timeout_s: float = 10.0) -> None:
    """Kill and reap every child of this process (orphaned Ray agents and workers included,
    as this is their subreaper) until none is left."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        children = children_of(os.getpid())
        if not children:
            return
        for pid in children:
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)
        with contextlib.suppress(ChildProcessError):
            while os.waitpid(-1, os.WNOHANG)[0]:
                pass
        time.sleep(0.05)


def children_of(pid: int) -> list[int]:
    """The child processes of `pid` (Linux /proc; none elsewhere)."""
    out: list[int] = []
    with contextlib.suppress(OSError):
        for task in os.listdir(f"/proc/{pid}/task"):
            with contextlib.suppress(OSError), open(f"/proc/{pid}/task/{task}/children") as f:
                out.extend(int(p) for p in f.read().split())
    return out


if __name__ == "__main__":
    main()
