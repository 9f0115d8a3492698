"""Connecting the driver to Ray: a cluster given by address, or a private local Ray.

Ray is an optional extra: nothing here imports it before a session is asked for, and a
missing Ray is a one-line error naming the pip command.
"""

from __future__ import annotations

import contextlib
import importlib.util
import logging
import os
import socket
from collections.abc import Iterator, Mapping
from typing import Any

from cocobench_agents.harness.ray_local import local_ray

INSTALL = "pip install 'cocobench-agents[ray]'"
CONNECT_TIMEOUT_S = 5.0


class RayUnavailable(ValueError):
    """Ray is not installed, or the cluster cannot be used as asked."""


def require_ray() -> None:
    """Raise `RayUnavailable` with the install command unless Ray can be imported."""
    try:
        found = importlib.util.find_spec("ray") is not None
    except ValueError:  # sys.modules["ray"] is None: imports of it are blocked
        found = False
    if not found:
        raise RayUnavailable(f"--executor ray needs Ray: {INSTALL}")


@contextlib.contextmanager
def ray_session(address: str | None = None, *, local_cpus: int = 2,
                local_gpus: float | None = None,
                runtime_env: dict[str, Any] | None = None) -> Iterator[None]:
    """The driver connected to the Ray cluster at `address` (``HOST:PORT`` of its head, or
    ``auto``), or to a private local Ray with `local_cpus` CPUs and `local_gpus` GPUs (None:
    those Ray detects) started for this block; disconnected (and the local Ray stopped with
    every process it started) when the block is left. A driver already connected (the
    caller ran `ray.init`) is used as it is."""
    require_ray()
    import ray

    if ray.is_initialized():
        yield
        return
    with contextlib.ExitStack() as stack:
        if address is None:
            local = stack.enter_context(local_ray(local_cpus, local_gpus))
            stack.enter_context(_environment(local.auth_env))
            address = local.address
        else:
            check_reachable(address)
        reload_ray_config()
        ray.init(address=address, runtime_env=runtime_env, log_to_driver=False,
                 logging_level=logging.ERROR)
        stack.callback(ray.shutdown)
        yield


def check_reachable(address: str) -> None:
    """Fail fast, with the remedy, when nothing listens at a ``HOST:PORT`` address (Ray
    itself would retry for minutes)."""
    host, sep, port = address.rpartition(":")
    if not sep or not port.isdigit():
        return  # "auto", "ray://…": Ray resolves those itself
    try:
        socket.create_connection((host, int(port)), timeout=CONNECT_TIMEOUT_S).close()
    except OSError as exc:
        raise RayUnavailable(
            f"--ray-address {address}: no Ray cluster answers there ({exc.strerror or exc}); "
            "start one with `ray start --head` and pass the address it prints "
            "(see docs/distributed.md)") from None


@contextlib.contextmanager
def _environment(values: Mapping[str, str]) -> Iterator[None]:
    saved = {name: os.environ.get(name) for name in values}
    os.environ.update(values)
    try:
        yield
    finally:
        for name, value in saved.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value


def reload_ray_config() -> None:
    """Have Ray re-read its authentication settings from the environment."""
    # Ray reads its authentication mode when it is imported; a process that imported Ray
    # before the local Ray's token was set must re-read it (what ray.init does for a Ray it
    # starts itself).
    with contextlib.suppress(ImportError, AttributeError):
        from ray._raylet import Config

        Config.initialize("")
