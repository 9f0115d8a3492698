"""The embedded world's invariants, and random play that checks them after every step.

`play(config, seed, steps)` runs one episode of random steps — menu calls, off-menu skill
calls (any object, any agent, bad numbers) and raw native calls (forced or not, bad numbers,
unknown ids) — checking after each: containment a forest whose contents lie within their
receptacle's bounds; held objects in no receptacle; one holder per object and one object per
hand; nothing visible that is shut in a closed container or in a teammate's hand; a refused
native action changes nothing; every number finite; every object's metadata record (kept
between steps while its inputs are unchanged) equal to one built afresh. At the end the
trajectory holds no non-finite number, and a replay of the same steps in a fresh world gives
the same bytes. The CI fuzz test (`tests/sim/test_invariants_fuzz.py`) and the full sweep
(`bench/sim_sweep.py`) both run it.
"""

from __future__ import annotations

import json
import math
import random
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

from benchmark_adapter.episode import Episode
from benchmark_adapter.sim.embedded.controller import EmbeddedController
from benchmark_adapter.sim.embedded.metadata import object_record
from benchmark_adapter.sim.embedded.vision import enclosed, visible
from benchmark_adapter.sim.embedded.world import World
from benchmark_adapter.skills.executor import EXPLORE, SKILLS
from benchmark_adapter.tasks.config import TaskConfig
from benchmark_adapter.trajectory import dumps

# Numbers a careless or adversarial caller passes: a few good ones among the bad.
MAGNITUDES = (0.25, 0.5, 150.0, 0.0, -0.25, -1e6, 1e6, 1e308, math.inf, -math.inf, math.nan)
DEGREES = (90.0, 30.0, 45.0, -90.0, 1e308, math.inf, math.nan)
COORDINATES = (0.0, 1e6, -1e308, math.inf, math.nan)
OBJECT_ACTIONS = ("PickupObject", "PutObject", "OpenObject", "CloseObject", "ToggleObjectOn",
                  "ToggleObjectOff", "SliceObject", "CleanObject", "DirtyObject",
                  "FillObjectWithLiquid", "EmptyLiquidFromObject", "PushObject", "PullObject",
                  "BreakObject", "GetInteractablePoses")
MOVES = ("MoveAhead", "MoveBack", "MoveLeft", "MoveRight")
UNKNOWN_ID = "Nothing|+00.00|+00.00|+00.00"


class InvariantBroken(AssertionError):
    """A step left the world breaking one of its invariants."""


@dataclass
class Played:
    """What one random episode did: its steps (to replay) and counts."""

    task_id: str
    seed: int
    steps: list[tuple[str, Any]] = field(default_factory=list)
    kinds: dict[str, int] = field(default_factory=dict)
    refused: int = 0


def play(config: TaskConfig, seed: int, steps: int) -> Played:
    """Random play of `steps` steps on `config`, every invariant checked after each; raises
    `InvariantBroken` naming the task, seed, step and breach."""
    rng = random.Random(f"{config.task_id}:{seed}")
    episode = _episode(config)
    played = Played(config.task_id, seed)
    for index in range(steps):
        step = _random_step(rng, episode)
        played.steps.append(step)
        played.kinds[step[0]] = played.kinds.get(step[0], 0) + 1
        try:
            refused = _apply_checked(episode, step)
        except InvariantBroken as exc:
            raise InvariantBroken(f"{config.task_id} seed {seed} step {index} {step}: {exc}") \
                from exc
        played.refused += refused
    text = _trajectory_text(episode, played)
    replay = _episode(config)
    for step in played.steps:
        _apply(replay, step)
    if _trajectory_text(replay, played) != text or state(replay.controller.world) != state(
            episode.controller.world):
        raise InvariantBroken(f"{config.task_id} seed {seed}: a replay differs")
    return played


def _episode(config: TaskConfig) -> Episode:
    episode = Episode(config, EmbeddedController(config))
    episode.reset()
    return episode


def _trajectory_text(episode: Episode, played: Played) -> str:
    document = episode.finish()
    try:
        json.dumps(document, allow_nan=False)  # the C encoder: fast on a long trajectory
    except ValueError:
        bad = next(_non_finite(document), "a non-finite number")
        raise InvariantBroken(
            f"{played.task_id} seed {played.seed}: the trajectory holds {bad}") from None
    return dumps(document)


def _non_finite(value: Any, where: str = "") -> Iterator[str]:
    if isinstance(value, float) and not math.isfinite(value):
        yield f"{value} at {where or '/'}"
    elif isinstance(value, dict):
        for key, item in value.items():
            yield from _non_finite(item, f"{where}/{key}")
    elif isinstance(value, list | tuple):
        for i, item in enumerate(value):
            yield from _non_finite(item, f"{where}[{i}]")


# -- steps --------------------------------------------------------------------------------

def _random_step(rng: random.Random, episode: Episode) -> tuple[str, Any]:
    kind = rng.choices(("menu", "skill", "native"), weights=(5, 2, 3))[0]
    world = episode.controller.world
    if kind == "menu":
        menu = episode.observe().action_menu
        if menu:
            return ("menu", rng.choice(menu).call)
        kind = "skill"
    agent = rng.randrange(len(world.agents))
    ids = sorted(world.objects)
    if kind == "skill":
        return ("skill", _random_call(rng, agent, ids))
    return ("native", _random_native(rng, agent, ids, world))


def _random_call(rng: random.Random, agent: int, ids: list[str]) -> str:
    skill = rng.choice(sorted(SKILLS))
    args: list[str] = []
    if skill == "Explore":
        args = [rng.choice(sorted(EXPLORE))]
    elif skill not in ("Wait", "Drop"):
        args = [rng.choice(ids)]
        if skill in ("PushObject", "PullObject") and rng.random() < 0.7:
            args.append(str(rng.choice(MAGNITUDES)))
    return f"{skill}({', '.join([f'agent_{agent + 1}', *args])})"


def _random_native(rng: random.Random, agent: int, ids: list[str],
                   world: World) -> tuple[str, int, dict[str, Any]]:
    roll = rng.random()
    if roll < 0.55:
        action = rng.choice(OBJECT_ACTIONS)
        kwargs: dict[str, Any] = {"objectId": rng.choice([*ids, UNKNOWN_ID]),
                                  "forceAction": rng.random() < 0.7}
        if action in ("PushObject", "PullObject"):
            kwargs["moveMagnitude"] = rng.choice(MAGNITUDES)
        return (action, agent, kwargs)
    if roll < 0.7:
        return (rng.choice(MOVES), agent, {"moveMagnitude": rng.choice(MAGNITUDES)})
    if roll < 0.8:
        return (rng.choice(("RotateLeft", "RotateRight", "LookUp", "LookDown")), agent,
                {"degrees": rng.choice(DEGREES)})
    if roll < 0.93:
        cells = sorted(world.floor)
        cx, cz = rng.choice(cells)
        x, z = cx * 0.25, cz * 0.25
        if rng.random() < 0.4:
            x, z = rng.choice(COORDINATES), rng.choice((z, *COORDINATES))
        return ("TeleportFull", agent, {
            "x": x, "y": 0.9, "z": z, "rotation": {"y": rng.choice((0.0, 90.0, *DEGREES))},
            "horizon": rng.choice((0.0, 30.0, 60.0, math.nan, math.inf)), "standing": True})
    return (rng.choice(("DropHandObject", "Pass", "GetReachablePositions")), agent,
            {"forceAction": True})


def _apply(episode: Episode, step: tuple[str, Any]) -> bool:
    """Run one step; whether it was a refused native action."""
    kind, body = step
    if kind == "native":
        action, agent, kwargs = body
        md = episode.controller.step(action, agentId=agent, **kwargs)
        return not md[agent]["lastActionSuccess"]
    episode.step(body)
    return False


def _apply_checked(episode: Episode, step: tuple[str, Any]) -> bool:
    world = episode.controller.world
    before = state(world)
    try:
        refused = _apply(episode, step)
    except Exception as exc:  # a step never raises: a refusal is reported, not thrown
        raise InvariantBroken(f"the step raised {exc!r}") from exc
    if refused and state(world) != before:
        raise InvariantBroken("a refused native action changed the world")
    check_world(world)
    check_records(episode.controller)
    return refused


# -- invariants ---------------------------------------------------------------------------

def state(world: World) -> str:
    """Everything a step may change, as canonical text: every field of every object and
    agent (a field added later included), but an object's affordances (fixed by its type)
    and an agent's last action."""
    objects = {oid: {k: v for k, v in vars(o).items() if k != "aff"}
               for oid, o in world.objects.items()}
    agents = [{k: v for k, v in vars(a).items() if not k.startswith("last_")}
              for a in world.agents]
    return json.dumps({"objects": objects, "agents": agents}, sort_keys=True)


def check_records(controller: EmbeddedController) -> None:
    """Raise `InvariantBroken` unless the metadata's object records (`ObjectTable` keeps
    each while what it reads is unchanged) are those `object_record` builds now."""
    world = controller.world
    for record in controller.last_metadata()[0]["objects"]:
        kept = {k: v for k, v in record.items() if k not in ("visible", "distance")}
        if kept != object_record(world, world.objects[record["objectId"]]):
            raise InvariantBroken(f"the metadata record of {record['objectId']} is stale")


def check_world(world: World) -> None:
    """Raise `InvariantBroken` unless every invariant of the module's docstring holds."""
    try:
        world.check_containment()  # a forest, contents in bounds, held in nothing, finite
    except Exception as exc:
        raise InvariantBroken(str(exc)) from exc
    hands = [a.held for a in world.agents if a.held is not None]
    if len(hands) != len(set(hands)):
        raise InvariantBroken(f"two agents hold the same object: {hands}")
    for agent in world.agents:
        if not all(math.isfinite(v) for v in (agent.x, agent.z, agent.yaw, agent.horizon)):
            raise InvariantBroken(f"{agent.name} has a non-finite pose")
        if agent.held is not None and world.objects[agent.held].held_by != agent.index:
            raise InvariantBroken(f"{agent.name} holds {agent.held}, which names another holder")
    for obj in world.objects.values():
        if obj.held_by is not None and world.agents[obj.held_by].held != obj.id:
            raise InvariantBroken(f"{obj.id} names agent_{obj.held_by + 1}, whose hand lacks it")
        shut, carrier = enclosed(world, obj), world.carrier(obj)
        for agent in world.agents:
            if (shut or carrier not in (None, agent.index)) and visible(world, agent, obj):
                raise InvariantBroken(f"{obj.id} is visible to {agent.name} although "
                                      f"{'shut in' if shut else 'in a teammate hand'}")
