"""Init actions, applied in order at reset on any backend (reference §2.3).

Failures are traced, never raised: an episode starts whatever its init actions did.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from benchmark_adapter.sim.protocol import Controller
from benchmark_adapter.skills.native import find_object

# Raw state-changing actions that the reference forces unless the config says otherwise.
FORCED_BY_DEFAULT = frozenset(
    {"DirtyObject", "CleanObject", "FillObjectWithLiquid", "EmptyLiquidFromObject"}
)


def apply_init_actions(
    controller: Controller, actions: list[dict[str, Any]]
) -> list[dict[str, Any]]:
    """Run every init action; return the trace `[{action, lastActionSuccess, errorMessage}]`."""
    return [_apply(controller, dict(action)) for action in actions]


def _apply(controller: Controller, action: dict[str, Any]) -> dict[str, Any]:
    kind = action.get("action")
    if kind == "assert_present":
        present = _object(controller, action.get("objectId")) is not None
        return _trace(action, present, "" if present else f"{action.get('objectId')} not present")
    if kind == "ensure_toggle_state":
        return _ensure_toggle(controller, action)
    if kind == "ensure_empty":
        return _ensure_empty(controller, action)
    if not isinstance(kind, str):
        return _trace(action, False, "init action without an 'action' name")
    kwargs = {k: v for k, v in action.items() if k != "action"}
    if kind in FORCED_BY_DEFAULT:
        kwargs.setdefault("forceAction", True)
    agent = kwargs.pop("agentId", None)
    own = controller.step(kind, agentId=agent, **kwargs)[agent or 0]
    return _trace(action, bool(own["lastActionSuccess"]), own["errorMessage"] or "")


def _ensure_toggle(controller: Controller, action: dict[str, Any]) -> dict[str, Any]:
    obj = _object(controller, action.get("objectId"))
    if obj is None:
        return _trace(action, False, f"{action.get('objectId')} not present")
    want = bool(action.get("isToggled"))
    if bool(obj.get("isToggled")) == want:
        return _trace(action, True, "already satisfied")
    native = "ToggleObjectOn" if want else "ToggleObjectOff"
    own = controller.step(native, agentId=0, objectId=obj["objectId"], forceAction=True)[0]
    return _trace(action, bool(own["lastActionSuccess"]), own["errorMessage"] or "")


def _ensure_empty(controller: Controller, action: dict[str, Any]) -> dict[str, Any]:
    obj = _object(controller, action.get("objectId"))
    if obj is None:
        return _trace(action, False, f"{action.get('objectId')} not present")
    if not obj.get("isFilledWithLiquid"):
        return _trace(action, True, "already satisfied")
    own = controller.step(
        "EmptyLiquidFromObject", agentId=0, objectId=obj["objectId"], forceAction=True
    )[0]
    return _trace(action, bool(own["lastActionSuccess"]), own["errorMessage"] or "")


def _object(controller: Controller, object_id: Any) -> Mapping[str, Any] | None:
    if not isinstance(object_id, str):
        return None
    return find_object(controller.last_metadata()[0], object_id)


def _trace(action: dict[str, Any], success: bool, error: str) -> dict[str, Any]:
    return {"action": action, "lastActionSuccess": success, "errorMessage": error}
