"""`EmbeddedController`: the embedded world behind the `Controller` protocol."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from benchmark_adapter.sim.embedded.actions import HANDLERS, ActionFailed
from benchmark_adapter.sim.embedded.metadata import (
    AgentMetadata,
    MetadataFactory,
    agent_record,
    inventory,
)
from benchmark_adapter.sim.embedded.world import AGENT_Y, World, ground_world
from benchmark_adapter.tasks.config import TaskConfig
from benchmark_adapter.vocabulary import EMBEDDED

# Queries leave the world as it is, so cached object records stay valid.
QUERIES = frozenset(
    {
        "GetReachablePositions",
        "GetInteractablePoses",
        "Pass",
        "Done",
        "InitialRandomSpawn",
        "AdvancePhysicsStep",
    }
)


class EmbeddedController:
    """A deterministic symbolic household world grounded from one task config.

    The same config and the same calls always give identical metadata.
    """

    backend = EMBEDDED

    def __init__(self, config: TaskConfig) -> None:
        self.config = config
        self.agent_count = config.init_state.controller_init.agentCount or config.agent_count
        self.world: World | None = None
        self._meta: MetadataFactory | None = None

    def reset(self) -> Sequence[AgentMetadata]:
        """Rebuild the scene from the config (init actions are applied by the caller)."""
        init = self.config.init_state
        self.world = ground_world(
            scene=self.config.scene_id,
            objects=init.objects,
            init_actions=init.init_actions,
            agent_count=self.agent_count,
            seed=self.config.seed,
            visibility_distance=init.controller_init.visibilityDistance,
        )
        self._meta = MetadataFactory(self.world, self.config.scene_id)
        return self._meta.snapshot()

    def step(
        self, action: str, agentId: int | None = None, **kwargs: Any
    ) -> Sequence[AgentMetadata]:
        """Run one native action; return every agent's metadata after it."""
        world, meta = self._require_reset()
        index = 0 if agentId is None else int(agentId)
        if not 0 <= index < len(world.agents):
            raise ValueError(f"agentId {agentId} out of range for {len(world.agents)} agents")
        agent = world.agents[index]
        if action not in QUERIES:
            meta.before_change()
        else:
            meta.before_action()
        result, error = None, ""
        handler = HANDLERS.get(action)
        try:
            if handler is None:
                raise ActionFailed(f"Invalid action: {action}")
            result = handler(world, agent, kwargs)
        except ActionFailed as exc:
            error = str(exc)
        except (KeyError, TypeError, ValueError) as exc:
            error = f"Invalid arguments for {action}: {exc!r}"
        agent.last_action, agent.last_success = action, not error
        agent.last_error, agent.last_return = error, result
        if action not in QUERIES:
            world.version += 1
        return meta.snapshot()

    def last_metadata(self) -> Sequence[AgentMetadata]:
        """Every agent's metadata now."""
        return self._require_reset()[1].snapshot()

    def frame(self, agent: int, width: int = 300, height: int = 300) -> bytes:
        """PNG of agent `agent`'s egocentric view."""
        from benchmark_adapter.sim.embedded.render import render_agent_frame

        return render_agent_frame(self._view(agent), width, height)

    def frame_rgb(self, agent: int, width: int = 300, height: int = 300,
                  out: Any = None) -> Any:
        """The pixels of `frame` as an RGB array (height, width, 3), no PNG encoded, written
        into `out` when given, else into a new array: what an environment's observation
        holds."""
        from benchmark_adapter.sim.embedded.render import agent_view_pixels

        return agent_view_pixels(self._view(agent), width, height, out)

    def _view(self, agent: int) -> dict[str, Any]:
        """What the renderer draws for agent `agent`: its pose, objects and the others.

        The objects are the shared records, without the agent's `visible` and `distance`
        (the renderer reads neither): its metadata's would test every object's visibility,
        a quarter of a frame's time when the picture is a kept one."""
        world, meta = self._require_reset()
        me = world.agents[agent]
        return {
            "agent": agent_record(me),
            "visibilityDistance": world.visibility_distance,
            "fieldOfView": 90,
            "objects": meta.table.records(),
            "inventoryObjects": inventory(world, me),
            "otherAgents": [
                {
                    "name": a.name,
                    "position": {"x": a.x, "y": AGENT_Y, "z": a.z},
                    "rotation": {"x": 0, "y": a.yaw, "z": 0},
                }
                for a in world.agents
                if a.index != agent
            ],
        }

    def stop(self) -> None:
        """Nothing to release: the world lives in this process."""
        self.world = None

    def _require_reset(self) -> tuple[World, MetadataFactory]:
        if self.world is None or self._meta is None:
            raise RuntimeError("EmbeddedController.reset() must be called first")
        return self.world, self._meta
