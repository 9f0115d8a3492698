"""What the four room categories contain: furniture, small objects and where each may lie.

Every type is a real AI2-THOR object type present in the embedded affordance table, so the
embedded world gives each one the affordances (and receptacle capacity) AI2-THOR would.
`scenes.py` turns a `RoomSpec` into concrete, seeded scenes.
"""

from __future__ import annotations

from dataclasses import dataclass

ROOMS = ("kitchen", "living_room", "bedroom", "bathroom")


@dataclass(frozen=True)
class Furniture:
    """A furniture type and how a scene places it.

    `where` is `wall` (along the walls), `center` (in the open middle), `switch` (on a wall,
    no footprint) or `in:Host,Host` (attached to host furniture: drawers in a dresser,
    cabinets under a counter); `count` is per room, or per host for attached pieces, and
    `limit` caps the room total. Attached pieces stack at the heights in `levels`.
    """

    type: str
    count: tuple[int, int]
    where: str = "wall"
    levels: tuple[float, ...] = (0.0,)
    limit: int = 99


@dataclass(frozen=True)
class ItemKind:
    """A small object type, the receptacle types it may spawn on or in, and how often a
    scene has one."""

    type: str
    hosts: tuple[str, ...]
    chance: float = 1.0


@dataclass(frozen=True)
class RoomSpec:
    """One room category: its size range, furniture and small objects."""

    room: str
    width: tuple[float, float]
    depth: tuple[float, float]
    furniture: tuple[Furniture, ...]
    items: tuple[ItemKind, ...]


def _kinds(hosts: str, chance: float, *types: str) -> tuple[ItemKind, ...]:
    return tuple(ItemKind(t, tuple(hosts.split()), chance) for t in types)


# Where the top of each surface is (item ids sit there) and how far from the surface's id an
# item may lie. Openable hosts hold their items inside, at the host's own height.
SURFACE_TOP = {
    "CounterTop": 0.95, "DiningTable": 0.78, "Desk": 0.78, "CoffeeTable": 0.47,
    "SideTable": 0.62, "Dresser": 0.92, "Sofa": 0.5, "ArmChair": 0.5, "Chair": 0.47,
    "Bed": 0.62, "TVStand": 0.52, "Ottoman": 0.47, "Toilet": 0.75, "Bathtub": 0.55,
    "TowelHolder": 1.05, "ToiletPaperHanger": 0.7, "GarbageCan": 0.1, "StoveBurner": 0.97,
}
SPREAD = {
    "CounterTop": 0.45, "DiningTable": 0.4, "Desk": 0.35, "CoffeeTable": 0.3, "Sofa": 0.45,
    "Bed": 0.45, "Dresser": 0.3, "Shelf": 0.25, "TVStand": 0.3, "Bathtub": 0.3,
}

KITCHEN = RoomSpec(
    room="kitchen",
    width=(4.5, 6.0),
    depth=(4.0, 5.5),
    furniture=(
        Furniture("Fridge", (1, 1)),
        Furniture("CounterTop", (2, 3), levels=(0.95,)),
        Furniture("GarbageCan", (1, 1)),
        Furniture("Shelf", (0, 1), levels=(1.2,)),
        Furniture("DiningTable", (0, 1), "center"),
        Furniture("Cabinet", (1, 2), "in:CounterTop", (0.4, 0.45)),
        Furniture("Drawer", (1, 2), "in:CounterTop", (0.78, 0.62)),
        Furniture("StoveBurner", (2, 2), "in:CounterTop", (0.95,), limit=2),
        Furniture("Microwave", (0, 1), "in:CounterTop", (1.05,), limit=1),
        Furniture("CoffeeMachine", (0, 1), "in:CounterTop", (0.95,), limit=1),
        Furniture("LightSwitch", (1, 1), "switch", (1.3,)),
    ),
    items=(
        *_kinds("CounterTop DiningTable Fridge", 0.9, "Potato", "Lettuce", "Tomato", "Apple"),
        *_kinds("CounterTop DiningTable Fridge", 0.7, "Bread", "Egg"),
        ItemKind("Knife", ("CounterTop", "Drawer", "DiningTable")),
        ItemKind("Plate", ("CounterTop", "DiningTable", "Cabinet"), 0.9),
        *_kinds("CounterTop DiningTable Cabinet", 0.7, "Bowl", "Mug", "Cup"),
        *_kinds("StoveBurner CounterTop Cabinet", 0.6, "Pan", "Pot", "Kettle"),
        *_kinds("Drawer CounterTop", 0.6, "Spatula", "Fork", "Spoon", "Ladle", "DishSponge"),
        *_kinds("CounterTop Shelf Cabinet", 0.5, "SaltShaker", "PepperShaker", "WineBottle"),
        ItemKind("SoapBottle", ("CounterTop",), 0.5),
    ),
)

LIVING_ROOM = RoomSpec(
    room="living_room",
    width=(4.5, 7.0),
    depth=(4.5, 7.0),
    furniture=(
        Furniture("Sofa", (1, 1)),
        Furniture("TVStand", (1, 1)),
        Furniture("ArmChair", (0, 2)),
        Furniture("SideTable", (1, 2)),
        Furniture("Shelf", (0, 2), levels=(0.8,)),
        Furniture("Dresser", (0, 1)),
        Furniture("GarbageCan", (1, 1)),
        Furniture("FloorLamp", (0, 1)),
        Furniture("CoffeeTable", (1, 1), "center"),
        Furniture("Ottoman", (0, 1), "center"),
        Furniture("DiningTable", (0, 1), "center"),
        Furniture("Drawer", (1, 3), "in:SideTable,Dresser,TVStand", (0.45, 0.3, 0.15)),
        Furniture("Television", (1, 1), "in:TVStand", (0.9,), limit=1),
        Furniture("LightSwitch", (1, 1), "switch", (1.3,)),
    ),
    items=(
        # Boxes first: other items may spawn inside them.
        *_kinds("CoffeeTable SideTable Shelf DiningTable TVStand Dresser", 0.85, "Box"),
        *_kinds("CoffeeTable SideTable Sofa ArmChair TVStand Shelf Drawer Box", 0.85,
                "KeyChain", "CreditCard", "RemoteControl", "Watch", "CellPhone"),
        *_kinds("CoffeeTable SideTable DiningTable Shelf Dresser Ottoman", 0.6,
                "Book", "Newspaper", "Laptop", "Pen", "Pencil", "TissueBox"),
        *_kinds("Shelf SideTable Dresser TVStand DiningTable", 0.6, "Statue", "Vase", "Candle"),
        *_kinds("Sofa ArmChair", 0.7, "Pillow"),
    ),
)

BEDROOM = RoomSpec(
    room="bedroom",
    width=(4.0, 6.0),
    depth=(4.0, 6.0),
    furniture=(
        Furniture("Bed", (1, 1)),
        Furniture("Desk", (1, 1)),
        Furniture("Dresser", (0, 1)),
        Furniture("SideTable", (1, 2)),
        Furniture("Shelf", (0, 2), levels=(0.9,)),
        Furniture("ArmChair", (0, 1)),
        Furniture("Chair", (0, 1), "center"),
        Furniture("GarbageCan", (1, 1)),
        Furniture("Drawer", (1, 3), "in:SideTable,Dresser,Desk", (0.5, 0.3, 0.15)),
        Furniture("DeskLamp", (0, 1), "in:Desk", (0.78,), limit=1),
        Furniture("LightSwitch", (1, 1), "switch", (1.3,)),
    ),
    items=(
        *_kinds("Desk SideTable Shelf Dresser", 0.7, "Box"),
        *_kinds("Desk SideTable Dresser Bed Shelf Drawer Box", 0.85,
                "KeyChain", "CreditCard", "CellPhone", "Watch", "AlarmClock"),
        *_kinds("Desk SideTable Shelf Dresser Bed", 0.6,
                "Book", "CD", "Laptop", "Pen", "Pencil", "Mug", "TissueBox"),
        *_kinds("Bed ArmChair", 0.7, "Pillow"),
        *_kinds("Bed Desk Shelf", 0.35, "TennisRacket", "BaseballBat", "BasketBall"),
    ),
)

BATHROOM = RoomSpec(
    room="bathroom",
    width=(3.0, 4.5),
    depth=(3.0, 4.5),
    furniture=(
        Furniture("Toilet", (1, 1)),
        Furniture("CounterTop", (1, 1), levels=(0.95,)),
        Furniture("Bathtub", (0, 1)),
        Furniture("Shelf", (0, 2), levels=(1.0,)),
        Furniture("TowelHolder", (1, 2), levels=(1.05,)),
        Furniture("ToiletPaperHanger", (1, 1), levels=(0.7,)),
        Furniture("GarbageCan", (1, 1)),
        Furniture("SideTable", (0, 1)),
        Furniture("Dresser", (0, 1)),
        Furniture("SinkBasin", (1, 1), "in:CounterTop", (0.85,), limit=1),
        Furniture("Cabinet", (1, 2), "in:CounterTop", (0.4, 0.45)),
        Furniture("Drawer", (1, 3), "in:CounterTop,Dresser,SideTable", (0.75, 0.6, 0.45)),
        Furniture("LightSwitch", (1, 1), "switch", (1.3,)),
    ),
    items=(
        *_kinds("CounterTop Shelf Toilet SideTable Dresser Drawer Cabinet", 0.85,
                "SoapBar", "SoapBottle", "SprayBottle", "Candle", "TissueBox"),
        *_kinds("CounterTop Shelf Drawer Dresser SideTable", 0.6, "Cloth", "DishSponge", "Watch"),
        ItemKind("ToiletPaper", ("ToiletPaperHanger", "Toilet", "Shelf", "Cabinet"), 0.9),
        ItemKind("HandTowel", ("TowelHolder", "CounterTop", "Shelf"), 0.9),
        ItemKind("Plunger", ("GarbageCan", "Toilet", "Bathtub"), 0.5),
    ),
)

ROOM_SPECS = {spec.room: spec for spec in (KITCHEN, LIVING_ROOM, BEDROOM, BATHROOM)}


def room_of_floorplan(scene: str) -> str:
    """The room category of an iTHOR FloorPlan (1–30 kitchen, 201–230 living room, 301–330
    bedroom, 401–430 bathroom)."""
    number = int(scene.removeprefix("FloorPlan").split("_")[0])
    rooms = {0: "kitchen", 2: "living_room", 3: "bedroom", 4: "bathroom"}
    if number // 100 not in rooms:
        raise ValueError(
            f"{scene}: not an iTHOR FloorPlan number (1-30, 201-230, 301-330, 401-430)"
        )
    return rooms[number // 100]
