"""How many instances each suite has of each task type, team size and room category.

`cocobench-full` has the paper's composition: D1 218, D2 225, D3 230, D4 224 instances; 415
two-agent, 288 three-agent, 194 four-agent. Each dimension keeps the reference's team-size
split (D1 126/58/34, D2 107/79/39, D3 80/78/72, D4 102/73/49), shared among its task types
after the reference's per-cell counts, with every task type present at every team size.
Within a task type and team size, instances are spread evenly over its room categories.

`cocobench-240` is stratified like the reference's rep240: 20 instances per dimension × team
size, shared among that stratum's task types in proportion to their counts (at least one
each), drawn with a seeded sample.
"""

from __future__ import annotations

import random
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from benchmark_adapter.generator.templates import TASK_TYPES
from benchmark_adapter.vocabulary import DIMENSIONS

TEAM_SIZES = (2, 3, 4)
FULL_COMPOSITION: dict[str, tuple[int, int, int]] = {
    # task type: instances with 2, 3, 4 agents
    "store_groceries": (13, 6, 4),
    "sort_and_store": (67, 24, 8),
    "tidy_drawers": (46, 28, 22),
    "stock_cabinet": (22, 6, 4),
    "load_in_order": (44, 33, 13),
    "fill_drawers_in_order": (41, 40, 22),
    "prepare_food": (80, 78, 72),
    "relay_items": (47, 27, 18),
    "indirect_relay": (10, 6, 4),
    "cross_zone_handoff": (45, 40, 27),
}
SUBSET_SIZE = 20  # per dimension × team size
SUBSET_SEED = 42  # as the reference's rep240


@dataclass(frozen=True)
class Stratum:
    """Instances wanted of one task type, team size and room category."""

    task_type: str
    agents: int
    room: str
    count: int


def full_strata() -> list[Stratum]:
    """Every (task type, team size, room) stratum of `cocobench-full`, in a fixed order."""
    strata = []
    for slug, counts in FULL_COMPOSITION.items():
        rooms = TASK_TYPES[slug].rooms
        for agents, count in zip(TEAM_SIZES, counts):
            for room, share in zip(rooms, spread(count, len(rooms), start=agents)):
                if share:
                    strata.append(Stratum(slug, agents, room, share))
    return strata


def spread(total: int, parts: int, start: int = 0) -> list[int]:
    """`total` split into `parts` near-equal shares; the remainder goes to the parts from
    `start` on (rotating with the team size, so no room is always the short one)."""
    shares = [total // parts] * parts
    for k in range(total % parts):
        shares[(start + k) % parts] += 1
    return shares


def subset_quota(counts: Mapping[str, int], size: int = SUBSET_SIZE) -> dict[str, int]:
    """Seats of a `size`-instance stratum per task type: one each, the rest by largest
    remainder in proportion to the task types' instance counts."""
    quota = dict.fromkeys(counts, 1)
    rest, total = size - len(counts), sum(counts.values())
    exact = {slug: rest * n / total for slug, n in counts.items()}
    for slug in counts:
        quota[slug] += int(exact[slug])
    left = size - sum(quota.values())
    by_remainder = sorted(counts, key=lambda s: (-(exact[s] - int(exact[s])), s))
    for slug in by_remainder[:left]:
        quota[slug] += 1
    return quota


def subset_ids(instances: Sequence[tuple[str, str, int, str]]) -> list[str]:
    """The `cocobench-240` task ids from (task id, dimension, team size, task type) rows."""
    rng = random.Random(SUBSET_SEED)
    chosen: list[str] = []
    for dim in DIMENSIONS:
        for agents in TEAM_SIZES:
            rows = [r for r in instances if r[1] == dim and r[2] == agents]
            counts = {slug: sum(r[3] == slug for r in rows) for slug in _types_of(rows)}
            for slug, seats in subset_quota(counts).items():
                pool = sorted(r[0] for r in rows if r[3] == slug)
                # min(): a partial generation (tests, slices) may have fewer than the quota.
                chosen += sorted(rng.sample(pool, min(seats, len(pool))))
    return chosen


def _types_of(rows: Sequence[tuple[str, str, int, str]]) -> list[str]:
    """Task types present, in the paper's order."""
    present = {r[3] for r in rows}
    return [slug for slug in TASK_TYPES if slug in present]
