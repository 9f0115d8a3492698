"""The cluster-wide limit on model calls in flight: one Ray actor per run hands out permits.

`--max-concurrency` is a limit per model across the whole cluster, so a sweep does not
exceed a provider's rate limit because it has more machines. Every Ray worker wraps its
remote clients in `LimitedClient`, which holds a permit from the run's `ConcurrencyLimiter`
around each call attempt (not around the backoff between attempts), on top of the client's
own per-process semaphore. Built-in models make no calls and take no permit.

Importing this module does not import Ray: `limiter_actor` makes the actor class on use.
"""

from __future__ import annotations

import asyncio
import uuid
from collections import defaultdict
from typing import Any

from cocobench_agents.models import ModelPool, ModelReply, ModelRequest, RemoteClient, RetryPolicy
from cocobench_agents.models.protocol import ModelClient

# Waiting `acquire` calls occupy the actor's concurrency slots: allow many.
LIMITER_CALLS_IN_FLIGHT = 100_000


class ConcurrencyLimiter:
    """Permits per model, at most `limit` out at once (an async Ray actor's body).

    A permit is a lease named by the caller, so a caller that gives up waiting can hand it
    back before it is granted, and the leases of a dead worker (its `holder`) can be
    returned by the driver.
    """

    def __init__(self, limit: int) -> None:
        self.limit = limit
        self._free: dict[str, asyncio.Semaphore] = {}
        self._leases: dict[str, tuple[str, str]] = {}  # lease → (model, holder)
        self._abandoned: set[str] = set()
        self.peak: defaultdict[str, int] = defaultdict(int)

    async def acquire(self, lease: str, model: str, holder: str) -> bool:
        """Wait for a permit for `model`; False if the lease was released meanwhile."""
        free = self._free.setdefault(model, asyncio.Semaphore(self.limit))
        await free.acquire()
        if lease in self._abandoned:
            self._abandoned.discard(lease)
            free.release()
            return False
        self._leases[lease] = (model, holder)
        self.peak[model] = max(self.peak[model], self.in_use(model))
        return True

    def release(self, lease: str) -> None:
        """Return a permit (or, if it is not granted yet, refuse it in advance)."""
        held = self._leases.pop(lease, None)
        if held is None:
            self._abandoned.add(lease)
        else:
            self._free[held[0]].release()

    def release_holder(self, holder: str) -> int:
        """Return every permit `holder` (a worker that died) still had; how many."""
        leases = [lease for lease, (_, h) in self._leases.items() if h == holder]
        for lease in leases:
            self.release(lease)
        return len(leases)

    def in_use(self, model: str) -> int:
        return sum(1 for m, _ in self._leases.values() if m == model)

    def stats(self) -> dict[str, Any]:
        """Permits out now and at most so far, per model."""
        return {"limit": self.limit, "peak": dict(self.peak),
                "in_use": {m: self.in_use(m) for m in self._free}}


def limiter_actor(limit: int, name: str) -> Any:
    """Start the run's `ConcurrencyLimiter` actor on the driver's node (it takes no CPU and
    dies with the driver)."""
    import ray
    from ray.util.scheduling_strategies import NodeAffinitySchedulingStrategy

    # Needing no CPU, it could be placed on any node, and die with a worker node that the
    # run outlives; on the driver's node it lasts as long as the run.
    here = NodeAffinitySchedulingStrategy(ray.get_runtime_context().get_node_id(), soft=False)
    actor_class = ray.remote(ConcurrencyLimiter)
    return actor_class.options(name=name, num_cpus=0, scheduling_strategy=here,
                               max_concurrency=LIMITER_CALLS_IN_FLIGHT).remote(limit)


class LimitedClient:
    """A remote client whose every attempt holds a permit of the run's limiter."""

    def __init__(self, inner: RemoteClient, limiter: Any, holder: str) -> None:
        self.inner, self.limiter, self.holder = inner, limiter, holder
        self.name = inner.name

    async def complete(self, request: ModelRequest) -> ModelReply:
        """As `RemoteClient.complete`: the run-level retry policy over `attempt`."""
        return await RetryPolicy.from_settings(self.inner.settings).complete(self, request)

    async def attempt(self, request: ModelRequest, number: int) -> ModelReply:
        """`RemoteClient.attempt`, holding a permit for `inner.model` meanwhile."""
        lease = uuid.uuid4().hex
        try:
            await self.limiter.acquire.remote(lease, self.inner.model, self.holder)
        except asyncio.CancelledError:
            self.limiter.release.remote(lease)  # refused in advance if not granted yet
            raise
        try:
            return await self.inner.attempt(request, number)
        finally:
            self.limiter.release.remote(lease)

    async def aclose(self) -> None:
        await self.inner.aclose()


class LimitedPool:
    """A `ModelPool` whose remote clients take permits from the run's limiter."""

    def __init__(self, pool: ModelPool, limiter: Any, holder: str) -> None:
        self.pool, self.limiter, self.holder = pool, limiter, holder
        self.settings = pool.settings
        self._wrapped: dict[str, LimitedClient] = {}

    def client(self, spec: str, *, episode: str, agent: str | None) -> ModelClient:
        client = self.pool.client(spec, episode=episode, agent=agent)
        if not isinstance(client, RemoteClient):
            return client
        wrapped = self._wrapped.get(spec)
        if wrapped is None:
            wrapped = self._wrapped[spec] = LimitedClient(client, self.limiter, self.holder)
        return wrapped

    def release(self, episode: str) -> None:
        self.pool.release(episode)

    async def aclose(self) -> None:
        await self.pool.aclose()
