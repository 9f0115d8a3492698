"""`max_concurrency` bounds the requests in flight per model; the rest queue."""

from __future__ import annotations

import asyncio

from cocobench_agents.models import ModelPool, ModelRequest

from .conftest import fast_settings
from .fake_openai import ok


def test_never_more_than_max_concurrency_in_flight(fake, make_client):
    fake.program(default=ok(delay_s=0.15))
    client = make_client(max_concurrency=2)

    async def burst():
        requests = [ModelRequest(f"prompt {i}") for i in range(8)]
        return await asyncio.gather(*(client.complete(r) for r in requests))

    replies = asyncio.run(burst())
    assert len(replies) == 8  # all queued, none rejected
    assert fake.count == 8
    assert fake.max_in_flight == 2


def test_pool_shares_the_limit_across_agents_and_episodes(fake, fake_key):
    fake.program(default=ok(delay_s=0.15))
    pool = ModelPool(fast_settings(fake, max_concurrency=2))
    clients = [
        pool.client("openai/fake-model", episode=f"ep{e}", agent=f"agent_{a}")
        for e in range(2)
        for a in range(3)
    ]
    assert all(c is clients[0] for c in clients)

    async def burst():
        return await asyncio.gather(
            *(c.complete(ModelRequest(f"p{i}")) for i, c in enumerate(clients))
        )

    asyncio.run(burst())
    assert fake.max_in_flight == 2


def test_a_new_event_loop_gets_a_working_limit(fake, make_client):
    # Runs call asyncio.run more than once; a semaphore bound to a closed loop must not break.
    fake.program(default=ok(delay_s=0.05))
    client = make_client(max_concurrency=1)

    async def burst():
        await asyncio.gather(*(client.complete(ModelRequest(f"x{i}")) for i in range(3)))

    asyncio.run(burst())
    asyncio.run(burst())
    assert fake.max_in_flight == 1
