"""`check_controller`: the embedded backend meets the contract on every demo instance and
every shared config; deliberately broken backends are caught."""

from __future__ import annotations

import functools
import io
import random
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import pytest
from PIL import Image

from benchmark_adapter.sim import Controller
from benchmark_adapter.sim.conformance import ConformanceError, check_controller
from benchmark_adapter.sim.embedded import EmbeddedController
from benchmark_adapter.sim.embedded.actions import HANDLERS
from benchmark_adapter.tasks import load_task, load_tasks
from tests.paths import SHARED_DATA

DATA = SHARED_DATA
TASKS = DATA / "tasks"
SHARED_FILES = sorted(TASKS.glob("*.json")) if TASKS.is_dir() else []
DEMO = load_tasks("demo")


@pytest.mark.parametrize("config", DEMO, ids=[t.task_id for t in DEMO])
def test_embedded_backend_conforms_on_demo(config) -> None:
    check_controller(lambda: EmbeddedController(config))


@pytest.mark.skipif(not TASKS.is_dir(), reason=f"shared CoCoBench data not found at {TASKS}")
@pytest.mark.parametrize("path", SHARED_FILES, ids=[p.stem for p in SHARED_FILES])
def test_embedded_backend_conforms_on_shared_configs(path: Path) -> None:
    config = load_task(path)
    check_controller(lambda: EmbeddedController(config))


def _has_two_portable_receptacles(config) -> bool:
    objects = EmbeddedController(config).reset()[0]["objects"]
    return sum(bool(o["pickupable"] and o["receptacle"]) for o in objects) >= 2


@functools.cache
def nesting() -> list:
    """The instances where the contract can try to put a receptacle into one it holds."""
    return [c for c in load_tasks("cocobench-full") if _has_two_portable_receptacles(c)]


@pytest.mark.slow
def test_embedded_backend_conforms_where_receptacles_can_nest() -> None:
    assert len(nesting()) >= 10
    for config in nesting():
        check_controller(lambda config=config: EmbeddedController(config))


def test_embedded_controller_satisfies_the_protocol() -> None:
    assert isinstance(EmbeddedController(DEMO[0]), Controller)


# -- broken backends --------------------------------------------------------------------------

CONFIG = DEMO[1]  # G_D1, two agents


def _patched(metadata: Sequence[Any], **changes: Any) -> list[dict[str, Any]]:
    return [{**dict(md), **changes} for md in metadata]


def _misreporting(when: Callable[[str], bool], **changes: Any) -> type[EmbeddedController]:
    """A backend whose metadata after the actions `when` picks carries `changes`."""

    class Misreporting(EmbeddedController):
        def step(self, action: str, agentId: int | None = None, **kwargs: Any):
            metadata = super().step(action, agentId, **kwargs)
            return _patched(metadata, **changes) if when(action) else metadata

    return Misreporting


# Reports success for actions it does not know.
UnknownActionSucceeds = _misreporting(
    lambda action: action not in HANDLERS, lastActionSuccess=True, errorMessage=""
)


class NoActionReturn(EmbeddedController):
    """Metadata without `actionReturn`."""

    def _strip(self, metadata):
        return [{k: md[k] for k in md if k != "actionReturn"} for md in metadata]

    def reset(self):
        return self._strip(super().reset())

    def step(self, action: str, agentId: int | None = None, **kwargs: Any):
        return self._strip(super().step(action, agentId, **kwargs))

    def last_metadata(self):
        return self._strip(super().last_metadata())


class ObjectsWithoutVisibility(EmbeddedController):
    """Object records without the `visible` flag."""

    def reset(self):
        return [{**dict(md), "objects": [{k: v for k, v in o.items() if k != "visible"}
                                         for o in md["objects"]]} for md in super().reset()]


class WrongAgentCount(EmbeddedController):
    """Returns metadata for one agent only."""

    def reset(self):
        return list(super().reset())[:1]


class Nondeterministic(EmbeddedController):
    """Each instance reports a different scene name."""

    def _tag(self, metadata):
        return _patched(metadata, sceneName=f"scene-{self._salt}")

    def reset(self):
        self._salt = random.random()
        return self._tag(super().reset())

    def step(self, action: str, agentId: int | None = None, **kwargs: Any):
        return self._tag(super().step(action, agentId, **kwargs))


class StealingPickup(EmbeddedController):
    """Lets a second agent take an object out of another agent's hand."""

    def step(self, action: str, agentId: int | None = None, **kwargs: Any):
        world = self.world
        if action == "PickupObject" and world is not None:
            obj = world.objects.get(kwargs.get("objectId"))
            if obj is not None and obj.held_by is not None and obj.held_by != agentId:
                world.agents[obj.held_by].held = None
                obj.held_by = None
        return super().step(action, agentId, **kwargs)


class TinyFrames(EmbeddedController):
    def frame(self, agent: int, width: int = 300, height: int = 300) -> bytes:
        out = io.BytesIO()
        Image.new("RGB", (120, 120)).save(out, format="PNG")
        return out.getvalue()


class JpegFrames(EmbeddedController):
    def frame(self, agent: int, width: int = 300, height: int = 300) -> bytes:
        return b"\xff\xd8\xff\xe0" + super().frame(agent, width, height)[4:]


class AllowsCycles(EmbeddedController):
    """Lets a held receptacle be put into what it contains (the bug of issue 24)."""

    def step(self, action: str, agentId: int | None = None, **kwargs: Any):
        if self.world is not None:
            self.world.lies_within = lambda obj, outer: obj.id == outer.id
        return super().step(action, agentId, **kwargs)


class LeavesContentsBehind(EmbeddedController):
    """A receptacle that moves leaves its contents where they lay (the bug of issue 41)."""

    def step(self, action: str, agentId: int | None = None, **kwargs: Any):
        if self.world is not None:
            self.world.descendants = lambda obj: []
        return super().step(action, agentId, **kwargs)


class ReportsAnObjectInsideItself(EmbeddedController):
    """After a Pass, lists the first receptacle among its own contents."""

    def step(self, action: str, agentId: int | None = None, **kwargs: Any):
        metadata = super().step(action, agentId, **kwargs)
        if action != "Pass":
            return metadata
        out = []
        for md in metadata:
            objects = [dict(o) for o in md["objects"]]
            box = next(o for o in objects if o["receptacle"])
            box["receptacleObjectIds"] = [*box["receptacleObjectIds"], box["objectId"]]
            out.append({**dict(md), "objects": objects})
        return out


FailingPass = _misreporting("Pass".__eq__, lastActionSuccess=False, errorMessage="nope")
# Accepts a teleport off the floor (reports success without moving).
TeleportAnywhere = _misreporting("TeleportFull".__eq__, lastActionSuccess=True, errorMessage="")


@pytest.mark.parametrize(("backend", "message"), [
    (UnknownActionSucceeds, "unknown action must fail"),
    (NoActionReturn, "actionReturn"),
    (ObjectsWithoutVisibility, "visible"),
    (WrongAgentCount, "expected 2 agents"),
    (Nondeterministic, "not deterministic"),
    (StealingPickup, "at most one holder"),
    (TinyFrames, "300"),
    (JpegFrames, "PNG"),
    (FailingPass, "Pass must succeed"),
    (TeleportAnywhere, "off the floor"),
])
def test_broken_backends_are_caught(backend: type, message: str) -> None:
    with pytest.raises(ConformanceError, match=message):
        check_controller(lambda: backend(CONFIG))


@pytest.mark.parametrize(("backend", "message"), [
    # The cycle is caught where the world first walks it: moving the put object's contents.
    (AllowsCycles, "after PutObject: the step raised ContainmentError"),
    (ReportsAnObjectInsideItself, "after Pass: an object lies inside itself"),
])
def test_backends_that_nest_an_object_in_itself_are_caught(backend: type, message: str) -> None:
    with pytest.raises(ConformanceError, match=message):
        check_controller(lambda: backend(nesting()[0]))


def test_a_backend_whose_receptacles_leave_their_contents_behind_is_caught() -> None:
    with pytest.raises(ConformanceError,
                       match=r"after PickupObject: \S+ lies \d+\.\d+ m from \S+, which lists"):
        check_controller(lambda: LeavesContentsBehind(nesting()[0]))


def test_conformance_error_is_an_assertion_error() -> None:
    assert issubclass(ConformanceError, AssertionError)


def test_check_controller_stops_both_controllers() -> None:
    made: list[EmbeddedController] = []

    def make() -> EmbeddedController:
        made.append(EmbeddedController(CONFIG))
        return made[-1]

    check_controller(make)
    assert len(made) == 2
    assert all(c.world is None for c in made)  # stop() releases the world

    made.clear()
    with pytest.raises(ConformanceError):
        check_controller(lambda: made.append(UnknownActionSucceeds(CONFIG)) or made[-1])
    assert len(made) == 2 and all(c.world is None for c in made)


class TeleportNeverWorks(EmbeddedController):
    """Every TeleportFull fails (reports an error, the agent stays put): Find can never work."""

    def step(self, action: str, agentId: int | None = None, **kwargs: Any):
        if action == "TeleportFull":
            return super().step("NoSuchTeleport", agentId)
        return super().step(action, agentId, **kwargs)


def test_a_backend_that_cannot_teleport_is_caught() -> None:
    with pytest.raises(ConformanceError):
        check_controller(lambda: TeleportNeverWorks(CONFIG))
