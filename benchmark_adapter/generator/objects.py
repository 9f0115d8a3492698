"""`SceneObject`: one object of a scene catalogue entry."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class SceneObject:
    """One object of a scene: its AI2-THOR id and type, its position (the one its id encodes),
    the receptacle it lies on or in (`parent`), and whether it is furniture."""

    id: str
    type: str
    x: float
    y: float
    z: float
    parent: str | None = None
    furniture: bool = False
