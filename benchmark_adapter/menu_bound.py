"""The largest action id the embedded world can give an instance's menu.

Action ids are indices in Γ, the global action list (`benchmark_adapter.menu`), which lists
every candidate object's phrases for every agent whatever is visible: so its length changes
only when the object set does, and in this world only slicing changes it (an object becomes
its pieces). The training environment sizes its action space with this bound, so that no
move can make a menu id its space cannot hold.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from benchmark_adapter.menu import PHRASES_PER_AGENT, candidate_objects, phrases_per_object
from benchmark_adapter.sim.embedded.affordances import affordances_of, slice_pieces
from benchmark_adapter.sim.embedded.controller import EmbeddedController
from benchmark_adapter.sim.embedded.world import make_object, referenced_ids
from benchmark_adapter.tasks.config import TaskConfig
from benchmark_adapter.vocabulary import AFFORDANCE_FLAGS


def largest_action_id(config: TaskConfig) -> int:
    """The largest action id any state of `config`'s episode can show (its Γ's length − 1
    at its longest: each sliceable object counted as itself or as its pieces, whichever
    lists more actions)."""
    init = config.init_state
    # The world's objects as its metadata lists them at reset, without grounding the world
    # (placing agents on the floor was 3/4 of this function's time).
    objects = [{"objectId": o.id, "objectType": o.type,
                **{flag: getattr(o.aff, flag) for flag in AFFORDANCE_FLAGS}}
               for o in map(make_object, referenced_ids(init.objects, init.init_actions))]
    per_agent = PHRASES_PER_AGENT + sum(_most_actions(o) for o in candidate_objects(objects))
    return EmbeddedController(config).agent_count * per_agent - 1


def _most_actions(obj: Mapping[str, Any]) -> int:
    """How many phrases `obj` adds to an agent's block of Γ at most: as itself, or sliced
    into its pieces."""
    whole = _actions(obj)
    if not obj.get("sliceable"):
        return whole
    piece_type, count = slice_pieces(obj["objectType"])
    piece = affordances_of(piece_type)
    flags = {flag: getattr(piece, flag) for flag in AFFORDANCE_FLAGS}
    if not any(flags.values()):  # pieces with no affordance are no candidates
        return whole
    return max(whole, count * _actions(flags))


def _actions(obj: Mapping[str, Any]) -> int:
    return phrases_per_object({"objectId": "", **obj})
