"""`Episode`: reset → observe → step(call) → evaluate → finish, on any backend."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

from benchmark_adapter import goals
from benchmark_adapter.menu import ActionSpace, MenuEntry, compact
from benchmark_adapter.scene_setup import apply_init_actions
from benchmark_adapter.sim.protocol import Controller
from benchmark_adapter.skills import SkillExecutor, SkillResult
from benchmark_adapter.tasks.config import TaskConfig
from benchmark_adapter.trajectory import state_record, trajectory_document, write_json_atomic


@dataclass
class Observation:
    """What a planner may know at one step."""

    step_index: int
    round_index: int
    agents: list[str]
    goal_text: str
    progress_text: str
    evaluation: dict[str, Any]
    action_menu: list[MenuEntry]
    inventories: dict[str, list[str]]
    messages: list[dict[str, Any]] = field(default_factory=list)
    frames: dict[str, bytes] = field(default_factory=dict)  # filled when Episode(frames=True)

    def menu_for(self, agent: str) -> list[MenuEntry]:
        """One agent's own menu entries."""
        return [e for e in self.action_menu if e.agent == agent]


class _GoalTexts(NamedTuple):
    """The goal and progress texts, and what they were rendered for: Γ (its aliases name
    the objects) and which checks passed."""

    space: ActionSpace
    passed: tuple[bool, ...]
    goal: str
    progress: str


class Episode:
    """One task instance on one backend, recording a reference-format trajectory."""

    def __init__(
        self,
        config: TaskConfig,
        controller: Controller | None = None,
        *,
        frames: bool = False,
        frame_size: int = 300,
    ) -> None:
        if controller is None:
            from benchmark_adapter.sim.embedded import EmbeddedController

            controller = EmbeddedController(config)
        self.config, self.controller = config, controller
        self.backend = getattr(controller, "backend", type(controller).__name__)
        self.frames, self.frame_size = frames, max(frame_size, 300)
        self.executor = SkillExecutor(controller)
        self.step_index = self.round_index = 0
        self.init_trace: list[dict[str, Any]] = []
        self.items: list[dict[str, Any]] = []
        self.board: list[dict[str, Any]] = []
        self._space: ActionSpace | None = None
        self._space_key: tuple = ()
        self._menu: list[MenuEntry] = []
        self._menu_key: tuple = ()
        # Γ and the compact menu by their keys, across steps and resets: the agents move
        # back and forth, so the same visibility comes back (bounded: cleared when full).
        self._spaces: dict[tuple, ActionSpace] = {}
        self._menus: dict[tuple, list[MenuEntry]] = {}
        self.goals = goals.GoalSet(config)
        self._texts: _GoalTexts | None = None  # the last step's, `_goal_texts`
        self._steps: list[dict[str, Any]] = []  # skill_result records, in order
        self._objects: list[dict[str, Any]] = []  # agent 0's objects now
        self._agents: list[dict[str, Any]] = []  # each agent's hand and last action now
        self._frame_cache: dict[tuple[int, str], bytes] = {}

    # -- lifecycle ---------------------------------------------------------------------

    def reset(self) -> Observation:
        """Reload the scene, apply init actions, record the `init` item."""
        self.controller.reset()
        self.init_trace = apply_init_actions(self.controller, self.config.init_state.init_actions)
        self.step_index = self.round_index = 0
        self.items, self.board, self._steps = [], [], []
        self._refresh()
        item = self._item("init")
        item["native_trace"] = self.init_trace
        self.items.append(item)
        return self.observe()

    def step(
        self,
        call: str,
        *,
        round_index: int | None = None,
        message: str | None = None,
        decision: dict[str, Any] | None = None,
    ) -> SkillResult:
        """Execute one skill call as one recorded step."""
        result = self.executor.execute(call)
        self.step_index += 1
        self._refresh()
        self._steps.append(result.to_dict())
        item = self._item(call, self._steps[-1])
        if round_index is not None:
            item["round_index"], item["message"] = round_index, message
        if decision is not None:
            item["policy_decision"] = decision
        self.items.append(item)
        return result

    def stop(self, decision: dict[str, Any]) -> None:
        """Record why the planner stopped (a `policy_stop` item)."""
        item = self._item("policy_stop")
        item["policy_decision"] = decision
        self.items.append(item)

    def post_messages(self, messages: list[dict[str, Any]]) -> None:
        """Append non-empty broadcast messages `{round, agent, text}` to the board."""
        self.board.extend(m for m in messages if m.get("text"))

    def finish(self, path: str | Path | None = None) -> dict[str, Any]:
        """The trajectory document; written atomically to `path` when given."""
        document = trajectory_document(self.config, self.init_trace, self.items)
        if path is not None:
            write_json_atomic(path, document)
        return document

    # -- queries -----------------------------------------------------------------------

    def observe(self) -> Observation:
        """The current observation: menu, goal, progress, inventories, frames."""
        space = self._space
        # The last recorded item was evaluated on exactly the current state.
        evaluation = self.items[-1]["eval"] if self.items else self.evaluate()
        goal_text, progress_text = self._goal_texts(space, evaluation)
        return Observation(
            step_index=self.step_index,
            round_index=self.round_index,
            agents=self.config.agent_ids,
            goal_text=goal_text,
            progress_text=progress_text,
            evaluation=evaluation,
            action_menu=self._compact_menu(),
            inventories=self.inventories(),
            messages=list(self.board),
            frames={a: self.frame(a) for a in self.config.agent_ids} if self.frames else {},
        )

    def evaluate(self) -> dict[str, Any]:
        """Goal check against agent 0's metadata and the recorded steps."""
        return self.goals.evaluate(self._objects, self._steps)

    def inventories(self) -> dict[str, list[str]]:
        """Held object ids per agent."""
        return {a: [o["objectId"] for o in md["inventoryObjects"]]
                for a, md in zip(self.config.agent_ids, self._agents)}

    def objects(self) -> list[dict[str, Any]]:
        """Agent 0's object metadata (privileged; for oracles and tools)."""
        return list(self._objects)

    # -- internals ---------------------------------------------------------------------

    def _refresh(self) -> None:
        metadata = self.controller.last_metadata()
        # Plain copies only: holding the backend's metadata would make it freeze every
        # agent's snapshot before the next change.
        self._objects = list(metadata[0]["objects"])
        self._agents = [{"inventoryObjects": list(md["inventoryObjects"]),
                         "lastActionSuccess": md["lastActionSuccess"],
                         "errorMessage": md["errorMessage"]} for md in metadata]
        # Γ only changes when an object appears, disappears or changes visibility to agent 0.
        key = tuple((o["objectId"], o.get("visible")) for o in self._objects)
        if key != self._space_key:
            space = self._spaces.get(key)
            if space is None:
                space = _bounded(self._spaces)[key] = ActionSpace.build(self.config.agent_ids,
                                                                        self._objects)
            self._space, self._space_key = space, key

    def _goal_texts(self, space: ActionSpace, evaluation: dict[str, Any]) -> tuple[str, str]:
        # The texts name objects by Γ's aliases and mark the checks passed: most steps change
        # neither, so they are the last step's.
        passed = tuple(bool(check["passed"]) for check in evaluation["checks"])
        texts = self._texts
        if texts is None or texts.space is not space or texts.passed != passed:
            texts = self._texts = _GoalTexts(
                space, passed, goals.goal_text(self.config, space.alias_of, self.goals),
                goals.progress_text(self.config, space.alias_of, evaluation, self.goals))
        return texts.goal, texts.progress

    def _compact_menu(self) -> list[MenuEntry]:
        # The compact menu changes with Γ, and in D4 with what lies on the buffer.
        relay = self.config.producer_consumer is not None
        key = (self._space_key, tuple(tuple(o.get("parentReceptacles") or ())
                                      for o in self._objects) if relay else None)
        if key != self._menu_key:
            menu = self._menus.get(key)
            if menu is None:
                menu = _bounded(self._menus)[key] = compact(self._space, self.config,
                                                            self._objects)
            self._menu, self._menu_key = menu, key
        return self._menu

    def _item(self, label: str, skill_result: dict[str, Any] | None = None) -> dict[str, Any]:
        item: dict[str, Any] = {"step_index": self.step_index, "label": label, "image": None,
                                "state": state_record(self.config, self._objects, self._agents)}
        if skill_result is not None:
            item["skill_result"] = skill_result
        # A step's eval includes the step itself (sliced_by): it is already in _steps.
        item["eval"] = self.evaluate()
        return item

    def frame(self, agent: str) -> bytes:
        """PNG of what `agent` sees now (rendered once per step, on demand)."""
        key = (len(self.items), agent)
        if key not in self._frame_cache:
            # Frames of earlier steps are stale: keep only this step's.
            self._frame_cache = {k: v for k, v in self._frame_cache.items() if k[0] == key[0]}
            index = self.config.agent_ids.index(agent)
            self._frame_cache[key] = self.controller.frame(index, self.frame_size,
                                                           self.frame_size)
        return self._frame_cache[key]

    def frame_pixels(self, agent: str, out: Any = None) -> Any:
        """What `frame` shows, as an RGB array (height, width, 3) the caller owns: written
        into `out` when given (a uint8 array of that shape), else a new array. The
        controller's own pixels where it gives them (`frame_rgb`: the embedded simulator's,
        no PNG encoded and decoded), else the PNG decoded."""
        pixels = getattr(self.controller, "frame_rgb", None)
        if pixels is not None:
            index = self.config.agent_ids.index(agent)
            return pixels(index, self.frame_size, self.frame_size, out)
        import io

        import numpy
        from PIL import Image

        array = numpy.asarray(Image.open(io.BytesIO(self.frame(agent))).convert("RGB"))
        if out is None:
            return array.copy()  # (asarray's may be read-only)
        out[...] = array
        return out


#: How many Γs (and compact menus) an episode keeps by key.
MENU_CACHE = 256


def _bounded(cache: dict[tuple, Any]) -> dict[tuple, Any]:
    """`cache`, emptied first when full."""
    if len(cache) >= MENU_CACHE:
        cache.clear()
    return cache
