"""`ThorController`: real AI2-THOR 5.0 behind the `Controller` protocol."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from benchmark_adapter.sim.thor.errors import ThorCrashed, ThorUnavailable
from benchmark_adapter.sim.thor.events import agent_metadata, frame_png
from benchmark_adapter.sim.thor.launch import ControllerFactory, open_controller
from benchmark_adapter.sim.thor.options import ThorOptions
from benchmark_adapter.sim.thor.pool import POOL, ControllerPool, Session
from benchmark_adapter.tasks.config import TaskConfig
from benchmark_adapter.vocabulary import AI2THOR

# Before these actions the reference points ai2thor's `last_event` at the acting agent's
# sub-event (its multi-agent workaround, reference §4.1); we do the same.
FOCUS_ACTIONS = frozenset({"OpenObject", "CloseObject"})


class ThorController:
    """One task config's episodes in a (pooled) AI2-THOR process.

    `reset()` always reloads the scene (InitialRandomSpawn is reproducible only right after a
    reset). Metadata comes back per agent as plain dicts; an action ai2thor rejects as invalid
    is an ordinary failed action, as in the embedded simulator. Use it as a context manager,
    or call `stop()`, to hand the AI2-THOR process back to the pool. Not thread-safe: one
    episode drives one controller. Options default to the `COCOBENCH_THOR_*` variables.
    """

    backend = AI2THOR

    def __init__(
        self,
        config: TaskConfig,
        options: ThorOptions | None = None,
        *,
        factory: ControllerFactory | None = None,
        pool: ControllerPool | None = None,
    ) -> None:
        self.config = config
        self.options = options or ThorOptions.from_env()
        self.agent_count = config.init_state.controller_init.agentCount or config.agent_count
        self.scene = config.init_state.controller_init.scene or config.scene_id
        if not self.scene.startswith("FloorPlan"):
            raise ValueError(
                f"{config.task_id}: scene {self.scene!r} is not an AI2-THOR scene (FloorPlan…); "
                "it exists only in the embedded simulator (--backend embedded)"
            )
        self._factory = open_controller if factory is None else factory
        self._pool = POOL if pool is None else pool
        self._session: Session | None = None
        self._event: Any = None  # the last ai2thor event; never handed out
        self._metadata: list[dict[str, Any]] = []
        self._ended: str | None = None
        self._reused = False

    # -- the Controller protocol ----------------------------------------------------------

    def init_parameters(self) -> dict[str, Any]:
        """AI2-THOR `Initialize` parameters of this config (reference §1, env.py)."""
        init = self.config.init_state.controller_init
        return {
            "agentMode": "default",
            "agentCount": self.agent_count,
            "gridSize": init.gridSize,
            "visibilityDistance": init.visibilityDistance,
            "renderImage": True,
        }

    def reset(self) -> Sequence[dict[str, Any]]:
        """Reload the scene with this config's agents (init actions are the caller's)."""
        try:
            return self._reset_once()
        except ThorCrashed:
            if not self._reused:
                raise
            # A pooled Unity may have died between episodes: start a fresh one, once.
            return self._reset_once()

    def step(
        self, action: str, agentId: int | None = None, **kwargs: Any
    ) -> Sequence[dict[str, Any]]:
        """Run one native action as agent `agentId`; every agent's metadata after it."""
        self._live()
        payload: dict[str, Any] = {"action": action, **kwargs}
        if agentId is not None:
            if not 0 <= int(agentId) < self.agent_count:
                raise ValueError(f"agentId {agentId} out of range for {self.agent_count} agents")
            payload["agentId"] = int(agentId)
        return self._call(lambda ctl: self._remember(_native_step(ctl, payload)))

    def last_metadata(self) -> Sequence[dict[str, Any]]:
        """Every agent's metadata after the most recent action."""
        self._live()
        return list(self._metadata)

    def frame(self, agent: int, width: int = 300, height: int = 300) -> bytes:
        """PNG of what agent `agent` saw after the most recent action."""
        self._live()
        return frame_png(self._event, agent, width, height)

    def stop(self) -> None:
        """Hand the AI2-THOR process back to the pool (or shut it down if `reuse` is off)."""
        session, self._session, self._event = self._session, None, None
        if session is None:
            return
        if self.options.reuse:
            self._pool.release(session, self)
        else:
            self._pool.discard(session)

    def close(self) -> None:
        """Shut this controller's AI2-THOR process down now."""
        session, self._session, self._event = self._session, None, None
        if session is not None:
            self._pool.discard(session)

    def __enter__(self) -> ThorController:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, *rest: Any) -> None:
        # Ctrl-C or SystemExit: the user is leaving, so do not keep Unity around for reuse.
        if exc_type is not None and not issubclass(exc_type, Exception):
            self.close()
        else:
            self.stop()

    # -- internals ------------------------------------------------------------------------

    def _reset_once(self) -> list[dict[str, Any]]:
        if self._session is None:
            key = (self._factory, self.options.pool_key())
            self._session = self._pool.acquire(key, self, self._start)
        self._reused, self._ended = self._session.uses > 1, None
        params = self.init_parameters()
        return self._call(lambda ctl: self._remember(ctl.reset(scene=self.scene, **params)))

    def _start(self) -> Any:
        return self._factory(self.options, self.scene, self.init_parameters())

    def _live(self) -> None:
        if self._ended is not None:
            raise ThorCrashed(f"{self._ended}; call reset() to start the episode again")
        if self._session is None or self._event is None:
            raise RuntimeError("ThorController.reset() must be called first")

    def _call(self, fn: Callable[[Any], Any]) -> Any:
        """Call into ai2thor; on any failure or interrupt, the session is shut down."""
        session = self._session
        assert session is not None
        try:
            return fn(session.controller)
        except BaseException as exc:
            # After an interrupted or failed exchange, Unity's state is unknown: never reuse it.
            self._session, self._event, self._metadata = None, None, []
            self._ended = f"AI2-THOR stopped after {type(exc).__name__}: {exc}"
            self._pool.discard(session)
            if isinstance(exc, Exception) and not isinstance(exc, (ThorUnavailable, ThorCrashed)):
                raise ThorCrashed(self._ended) from exc
            raise

    def _remember(self, event: Any) -> list[dict[str, Any]]:
        self._event = event
        self._metadata = agent_metadata(event)
        if len(self._metadata) != self.agent_count:
            raise ThorCrashed(
                f"AI2-THOR returned {len(self._metadata)} agents' metadata, "
                f"expected {self.agent_count}"
            )
        return list(self._metadata)


def _native_step(ctl: Any, payload: dict[str, Any]) -> Any:
    """`ctl.step(payload)` with the reference's Open/Close focus and ai2thor's ValueError undone.

    ai2thor raises ValueError for InvalidAction/InvalidArgument/MissingArguments replies, after
    it has stored the reply as `last_event`; that reply is an ordinary failed action.
    """
    previous = ctl.last_event
    agent = payload.get("agentId")
    sub_events = getattr(previous, "events", None)
    if agent is not None and payload["action"] in FOCUS_ACTIONS and sub_events:
        ctl.last_event = sub_events[agent]
    before = ctl.last_event
    try:
        return ctl.step(payload)
    except ValueError:
        if ctl.last_event is before:  # raised before any reply arrived: a real error
            ctl.last_event = previous
            raise
        return ctl.last_event
