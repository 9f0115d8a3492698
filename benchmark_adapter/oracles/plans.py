"""Privileged reference plans for the nine released cells (reference §8).

A plan is a generator of skill-call strings; the runner sends each call's `SkillResult` back
in (the released plans are open-loop and ignore it). Plans know the config's aliases.
"""

from __future__ import annotations

import re
from collections.abc import Generator, Iterable

from benchmark_adapter.skills import SkillResult
from benchmark_adapter.tasks.config import TaskConfig

Plan = Generator[str, SkillResult | None, None]
VACATE = ("back", "left", "right", "back")


def call(skill: str, agent: str, *args: str) -> str:
    """A skill-call string."""
    return f"{skill}({', '.join((agent, *args))})"


def numbered(config: TaskConfig, prefix: str) -> list[str]:
    """Aliases `prefix1`, `prefix_2`, … in numeric order."""
    pattern = re.compile(rf"^{re.escape(prefix)}_?(\d+)$")
    found = [(int(m.group(1)), a) for a in config.init_state.objects if (m := pattern.match(a))]
    return [a for _, a in sorted(found)]


def _each(calls: Iterable[str]) -> Plan:
    """Yield calls one by one (a list iterator would reject the runner's `send`)."""
    for c in calls:  # noqa: UP028 - a plain loop, so that `send` reaches this generator
        yield c


def _carry(agent: str, item: str, dest: str) -> list[str]:
    """Fetch `item` and put it into/onto `dest`."""
    return [
        call("Find", agent, item),
        call("PickUp", agent, item),
        call("Find", agent, dest),
        call("Put", agent, dest),
    ]


def _explore(agent: str, directions: Iterable[str]) -> list[str]:
    return [call("Explore", agent, d) for d in directions]


def _first_alias(config: TaskConfig, *names: str) -> str:
    for name in names:
        if name in config.init_state.objects:
            return config.resolve(name)
    raise KeyError(f"{config.task_id}: none of the aliases {names} is defined")


def plan_a_d1(config: TaskConfig) -> Plan:
    """agent_1 opens the fridge and stores the potato; agent_2 turns the light off and stores
    the lettuce. The fridge is left open (a loaded fridge cannot be closed, reference §10.2)."""
    o = config.resolve
    a1, a2 = config.agent_ids[:2]
    fridge = o("fridge")
    yield from _each(
        [
            call("Find", a1, fridge),
            call("Open", a1, fridge),
            *_carry(a1, o("potato"), fridge),
            call("Explore", a1, "back"),
            call("Find", a2, o("light")),
            call("ToggleOff", a2, o("light")),
            *_carry(a2, o("lettuce"), fridge),
        ]
    )


def plan_c_d2(config: TaskConfig) -> Plan:
    """Open the container, deal the items round-robin, the last loader closes it."""
    agents, container = config.agent_ids, config.resolve("container")
    items = numbered(config, "item")
    yield call("Find", agents[0], container)
    yield call("Open", agents[0], container)
    for k, item in enumerate(items):
        a = agents[k % len(agents)]
        yield from _each(
            [*_carry(a, config.resolve(item), container), *_explore(a, ("back", "left"))]
        )
    last = agents[(len(items) - 1) % len(agents)]
    yield call("Find", last, container)
    yield call("Close", last, container)


def plan_c_d4(config: TaskConfig) -> Plan:
    """Relay every item through the buffer, one at a time, producers and consumers in turn."""
    items = numbered(config, "item") or numbered(config, "food")
    buffer = _first_alias(config, "transfer_plate", "transfer")
    target = _first_alias(config, "fridge", "target_pot", "target")
    producers = config.producers() or [config.agent_ids[0]]
    consumers = config.consumers() or [config.agent_ids[1]]
    if "fridge" in config.init_state.objects:
        c = consumers[0]
        yield from _each(
            [call("Find", c, target), call("Open", c, target), *_explore(c, ("back", "left"))]
        )
    for k, alias in enumerate(items):
        item, p, c = (
            config.resolve(alias),
            producers[k % len(producers)],
            consumers[k % len(consumers)],
        )
        yield from _each([*_carry(p, item, buffer), *_explore(p, VACATE)])
        yield from _each([*_carry(c, item, target), *_explore(c, VACATE)])


def plan_g_d1(config: TaskConfig) -> Plan:
    """Each agent moves its own item onto its own target."""
    for i, a in enumerate(config.agent_ids, 1):
        item, target = config.resolve(f"item_{i}"), config.resolve(f"target_{i}")
        yield from _each(_carry(a, item, target))


def plan_h_d1(config: TaskConfig) -> Plan:
    """Each agent opens its own drawer and stores its own item."""
    for i, a in enumerate(config.agent_ids, 1):
        item, drawer = config.resolve(f"item_{i}"), config.resolve(f"drawer_{i}")
        yield from _each(
            [call("Find", a, drawer), call("Open", a, drawer), *_carry(a, item, drawer)]
        )


def plan_k_d3(config: TaskConfig) -> Plan:
    """Agents take the knife in turn, slice their assigned items, drop it and step away."""
    knife = config.resolve("knife")
    items = numbered(config, "item")
    assignment = config.assignment or {f"item_{i}": a for i, a in enumerate(config.agent_ids, 1)}
    for a in sorted(set(assignment.values())):
        mine = [config.resolve(i) for i in items if assignment.get(i) == a]
        yield from _each([call("Find", a, knife), call("PickUp", a, knife)])
        for item in mine:
            yield from _each([call("Find", a, item), call("Slice", a, item)])
        yield call("Drop", a)
        yield from _each(_explore(a, VACATE))


ORACLE_PLANS = {
    "A_D1": plan_a_d1,
    "A_D2": plan_c_d2,
    "C_D2": plan_c_d2,
    "H_D2": plan_c_d2,
    "C_D4": plan_c_d4,
    "J_D4": plan_c_d4,
    "G_D1": plan_g_d1,
    "H_D1": plan_h_d1,
    "K_D3": plan_k_d3,
}
