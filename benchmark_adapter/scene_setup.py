"""Init actions, applied in order at reset on any backend (reference §2.3).

Failures are traced, never raised: an episode starts whatever its init actions did.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from benchmark_adapter.sim.protocol import Controller
from benchmark_adapter.skills.native import find_object

# Raw state-changing actions that the reference forces unless the config says otherwise.
FORCED_BY_DEFAULT = frozenset({"DirtyObject", "CleanObject", "FillObjectWithLiquid",
                               "EmptyLiquidFromObject"})


def apply_init_actions(controller: Controller, actions: list[dict[str, Any]]
                       ) -> list[dict[str, Any]]:
    """Run every init action; return the trace `[{action, lastActionSuccess, errorMessage}]`."""
    return [_apply(controller, dict(action)) for action in actions]


def _apply(controller: Controller, action: dict[str, Any]) -> dict[str, Any]:
    kind, object_id = action.get("action"), action.get("objectId")
    if kind == "assert_present":
        present = _object(controller, object_id) is not None
        return _trace(action, present, "" if present else f"object not present: {object_id}")
    if kind == "ensure_toggle_state":
        obj, want = _object(controller, object_id), bool(action.get("isToggled"))
        if obj is None or bool(obj.get("isToggled")) == want:  # the reference's rule
            return _trace(action, True, "already satisfied")
        native = "ToggleObjectOn" if want else "ToggleObjectOff"
        return native_step(controller, {"action": native, "objectId": object_id,
                                        "forceAction": True, "agentId": 0})
    if kind == "ensure_empty":
        obj = _object(controller, object_id)
        if obj is None or not obj.get("isFilledWithLiquid"):
            return _trace(action, True, "already empty")
        return native_step(controller, {"action": "EmptyLiquidFromObject",
                                        "objectId": object_id, "agentId": 0})
    if kind in FORCED_BY_DEFAULT:
        action.setdefault("forceAction", True)
    return native_step(controller, action)


def native_step(controller: Controller, action: dict[str, Any]) -> dict[str, Any]:
    """Run one native action as its `agentId` (default: the backend's) and trace it.

    As in the reference, success is read from agent 0's metadata, and an exception becomes a
    failed trace entry.
    """
    kwargs = {k: v for k, v in action.items() if k not in ("action", "agentId")}
    try:
        if not isinstance(action.get("action"), str):
            raise ValueError("init action without an 'action' name")
        own = controller.step(action["action"], agentId=action.get("agentId"), **kwargs)[0]
    except Exception as exc:  # noqa: BLE001 - init failures never abort an episode
        return _trace(action, False, repr(exc))
    return _trace(action, bool(own["lastActionSuccess"]), own["errorMessage"] or "")


def _object(controller: Controller, object_id: Any) -> Mapping[str, Any] | None:
    if not isinstance(object_id, str):
        return None
    return find_object(controller.last_metadata()[0], object_id)


def _trace(action: dict[str, Any], success: bool, error: str) -> dict[str, Any]:
    return {"action": action, "lastActionSuccess": success, "errorMessage": error}
