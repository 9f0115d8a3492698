"""Identifiers the generator writes: object ids, scene ids and task ids.

Object ids follow AI2-THOR (`Type|+x.xx|+y.yy|+z.zz`, sign-prefixed, two decimals, two integer
digits) because the embedded world reads an object's position from its id. Scene ids are
`Emb<Room><NN>` so they can never be mistaken for iTHOR's `FloorPlanN`.
"""

from __future__ import annotations

ROOM_SCENE_PREFIX = {
    "kitchen": "EmbKitchen",
    "living_room": "EmbLivingRoom",
    "bedroom": "EmbBedroom",
    "bathroom": "EmbBathroom",
}


def coordinate(value: float) -> str:
    """One id coordinate: `+01.40`, `-00.06` (never `-00.00`)."""
    rounded = round(value, 2) + 0.0  # + 0.0 turns -0.0 into 0.0
    return f"{rounded:+06.2f}"


def object_id(object_type: str, x: float, y: float, z: float) -> str:
    """An AI2-THOR object id for a type at a position."""
    return f"{object_type}|{coordinate(x)}|{coordinate(y)}|{coordinate(z)}"


def unique_object_id(
    object_type: str, x: float, y: float, z: float, taken: set[str]
) -> tuple[str, float]:
    """An id no object of `taken` has, and the x it encodes: two objects on one spot are told
    apart by nudging the later one sideways. The id is added to `taken`."""
    oid = object_id(object_type, x, y, z)
    while oid in taken:
        x += 0.01
        oid = object_id(object_type, x, y, z)
    taken.add(oid)
    return oid, x


def scene_id(room: str, index: int) -> str:
    """The id of embedded scene `index` (1-based) of a room category: `EmbKitchen07`."""
    return f"{ROOM_SCENE_PREFIX[room]}{index:02d}"


def task_id(cell: str, scene: str, slug: str, agents: int, seed: int) -> str:
    """`<cell>__<scene>__<task type>_[<N>agent_]seed<S>`, as the reference names instances
    (two-agent ids carry no agent count)."""
    team = "" if agents == 2 else f"{agents}agent_"
    return f"{cell}__{scene}__{slug}_{team}seed{seed}"
