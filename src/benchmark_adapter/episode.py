"""`Episode`: reset → observe → step(call) → evaluate → finish, on any backend."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from benchmark_adapter import goals
from benchmark_adapter.menu import ActionSpace, MenuEntry, compact
from benchmark_adapter.scene_setup import apply_init_actions
from benchmark_adapter.sim.protocol import Controller, Metadata
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

    def entry(self, action_id: int, agent: str | None = None) -> MenuEntry | None:
        """The menu entry with this id (restricted to `agent`'s menu when given)."""
        for e in self.action_menu:
            if e.action_id == action_id and (agent is None or e.agent == agent):
                return e
        return None


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
        self._frame_cache: dict[tuple[int, str], bytes] = {}
        self._metadata: list[Metadata] = []

    # -- lifecycle ---------------------------------------------------------------------

    def reset(self) -> Observation:
        """Reload the scene, apply init actions, record the `init` item."""
        self.controller.reset()
        self.init_trace = apply_init_actions(self.controller, self.config.init_state.init_actions)
        self.step_index = self.round_index = 0
        self.items, self.board = [], []
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
        item = self._item(call, result.to_dict())
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
        objects = self._metadata[0]["objects"]
        evaluation = self.evaluate()
        return Observation(
            step_index=self.step_index,
            round_index=self.round_index,
            agents=self.config.agent_ids,
            goal_text=goals.goal_text(self.config, space.alias_of),
            progress_text=goals.progress_text(self.config, space.alias_of, evaluation),
            evaluation=evaluation,
            action_menu=compact(space, self.config, objects),
            inventories=self.inventories(),
            messages=list(self.board),
            frames={a: self.frame(a) for a in self.config.agent_ids} if self.frames else {},
        )

    def evaluate(self) -> dict[str, Any]:
        """Goal check against agent 0's metadata and the recorded steps."""
        steps = [i["skill_result"] for i in self.items if "skill_result" in i]
        return goals.evaluate(self.config, self._metadata[0]["objects"], steps)

    def inventories(self) -> dict[str, list[str]]:
        """Held object ids per agent."""
        return {
            a: [o["objectId"] for o in md["inventoryObjects"]]
            for a, md in zip(self.config.agent_ids, self._metadata)
        }

    def objects(self) -> list[dict[str, Any]]:
        """Agent 0's object metadata (privileged; for oracles and tools)."""
        return list(self._metadata[0]["objects"])

    # -- internals ---------------------------------------------------------------------

    def _refresh(self) -> None:
        self._metadata = list(self.controller.last_metadata())
        objects = self._metadata[0]["objects"]
        # Γ only changes when an object appears, disappears or changes visibility to agent 0.
        key = tuple((o["objectId"], o.get("visible")) for o in objects)
        if key != self._space_key:
            self._space = ActionSpace.build(self.config.agent_ids, objects)
            self._space_key = key

    def _item(self, label: str, skill_result: dict[str, Any] | None = None) -> dict[str, Any]:
        item: dict[str, Any] = {
            "step_index": self.step_index,
            "label": label,
            "image": None,
            "state": state_record(self.config, self._metadata),
        }
        steps = [i["skill_result"] for i in self.items if "skill_result" in i]
        if skill_result is not None:  # a step's eval includes the step itself (sliced_by)
            item["skill_result"] = skill_result
            steps.append(skill_result)
        item["eval"] = goals.evaluate(self.config, self._metadata[0]["objects"], steps)
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
