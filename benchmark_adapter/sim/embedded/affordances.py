"""What each object type can do, after the paper's action-space table (appendix, Table skill-set).

Types are AI2-THOR object types. Capacities are how many objects a receptacle holds before
`PutObject` refuses with "No valid positions"; heights and footprints give the world its
geometry (visibility of tall furniture, floor cells an agent cannot stand on).
"""

from __future__ import annotations

from dataclasses import dataclass

from benchmark_adapter.vocabulary import AFFORDANCE_FLAGS

# The flags that put an object in the menu, plus cookable (a state, not a menu affordance).
FLAGS = (*AFFORDANCE_FLAGS, "cookable")


@dataclass(frozen=True)
class Affordances:
    """Affordance flags and simple geometry of one object type."""

    pickupable: bool = False
    receptacle: bool = False
    openable: bool = False
    toggleable: bool = False
    sliceable: bool = False
    dirtyable: bool = False
    canFillWithLiquid: bool = False
    breakable: bool = False
    moveable: bool = False
    cookable: bool = False
    capacity: int = 0
    height: float = 0.12
    footprint: float = 0.0

    def any(self) -> bool:
        """Whether the type has at least one affordance (and so gets menu entries)."""
        return any(getattr(self, flag) for flag in FLAGS)


def _types(text: str) -> frozenset[str]:
    return frozenset(text.split())


# The paper's table, one set per affordance; a few kitchen/bath types the generator needs added.
PICKUPABLE = _types("""AlarmClock Apple BaseballBat BasketBall Book Bowl Box Bread ButterKnife
    Candle CD CellPhone Cloth CreditCard Cup DishSponge Egg Fork GlassBottle HandTowel Kettle
    KeyChain Knife Ladle Laptop Lettuce Mug Newspaper Pan Pen Pencil PepperShaker Plate Plunger
    Potato RemoteControl SaltShaker SoapBar SoapBottle Spatula SprayBottle Spoon Statue
    TennisRacket TissueBox Tomato Vase Watch WateringCan WineBottle Pot ToiletPaper Pillow""")
RECEPTACLE = _types("""ArmChair Bed Box Cabinet Chair CoffeeTable CounterTop Desk DiningTable
    Drawer Dresser Fridge Microwave Plate Safe Shelf SideTable Sink Sofa Bowl Pot Pan Mug Cup
    GarbageCan Ottoman TVStand Toilet Bathtub SinkBasin BathtubBasin StoveBurner
    ToiletPaperHanger TowelHolder CoffeeMachine""")
OPENABLE = _types("Box Cabinet Drawer Fridge Laptop Microwave Safe Kettle")
TOGGLEABLE = _types(
    "DeskLamp Faucet FloorLamp LightSwitch Microwave CoffeeMachine StoveKnob Television Laptop"
)
SLICEABLE = _types("Apple Bread Lettuce Potato Tomato")
DIRTYABLE = _types("""Apple Bowl Cloth Cup DishSponge Egg Fork Kettle Knife Lettuce Mug Pan Plate
    Potato SoapBottle Spatula Tomato Vase Pot Bed""")
FILLABLE = _types("Bowl Cup Kettle Mug Pan Plate Pot Vase WateringCan")
MOVEABLE = _types("""ArmChair BasketBall Box Chair CoffeeTable DiningTable Dresser GarbageCan
    Ottoman Pillow SideTable Sofa Statue""")
BREAKABLE = _types("""Bottle Bowl CellPhone Cup DishSponge Egg GlassBottle Laptop Mirror Mug
    Plate Statue Television Vase Window WineBottle""")
COOKABLE = _types("Potato Egg Bread BreadSliced PotatoSliced EggCracked")

# How many objects fit before "No valid positions"; sized like AI2-THOR's free surface area.
CAPACITY = {
    "Plate": 3,
    "Bowl": 2,
    "Cup": 1,
    "Mug": 1,
    "Pot": 2,
    "Pan": 2,
    "Box": 4,
    "Drawer": 4,
    "Cabinet": 6,
    "Safe": 3,
    "Microwave": 2,
    "Fridge": 10,
    "Sink": 4,
    "SinkBasin": 4,
    "GarbageCan": 4,
    "Shelf": 4,
    "SideTable": 5,
    "Dresser": 8,
    "Desk": 8,
    "CoffeeTable": 8,
    "DiningTable": 12,
    "CounterTop": 16,
    "Sofa": 8,
    "ArmChair": 4,
    "Chair": 2,
    "Bed": 10,
    "Ottoman": 3,
    "TVStand": 6,
    "Toilet": 2,
    "Bathtub": 4,
    "BathtubBasin": 4,
    "StoveBurner": 1,
    "ToiletPaperHanger": 1,
    "TowelHolder": 1,
    "CoffeeMachine": 1,
}

# Vertical extent above the id's position (furniture ids sit at floor level).
HEIGHT = {
    "Fridge": 1.8,
    "Sofa": 0.8,
    "Bed": 0.6,
    "Desk": 0.75,
    "DiningTable": 0.75,
    "CoffeeTable": 0.45,
    "SideTable": 0.6,
    "Dresser": 0.9,
    "ArmChair": 0.8,
    "Chair": 0.9,
    "Cabinet": 0.4,
    "Drawer": 0.15,
    "Shelf": 0.3,
    "Box": 0.3,
    "Microwave": 0.3,
    "GarbageCan": 0.4,
    "Ottoman": 0.45,
    "TVStand": 0.5,
    "Toilet": 0.6,
    "Bathtub": 0.5,
    "FloorLamp": 1.6,
    "Television": 0.6,
    "Safe": 0.4,
}

# Radius of floor an object blocks (agents stand on a 0.25 m grid outside it).
FOOTPRINT = {
    "Fridge": 0.45,
    "Sofa": 0.6,
    "Bed": 0.8,
    "Desk": 0.4,
    "DiningTable": 0.5,
    "CoffeeTable": 0.35,
    "SideTable": 0.25,
    "Dresser": 0.35,
    "ArmChair": 0.35,
    "Chair": 0.25,
    "CounterTop": 0.35,
    "Cabinet": 0.25,
    "Drawer": 0.25,
    "Ottoman": 0.25,
    "TVStand": 0.3,
    "Toilet": 0.3,
    "Bathtub": 0.6,
    "GarbageCan": 0.15,
    "FloorLamp": 0.15,
    "Safe": 0.2,
    "Sink": 0.25,
    "Shelf": 0.2,
}


def affordances_of(object_type: str) -> Affordances:
    """Affordances of an AI2-THOR object type (unknown types have none)."""
    return _TABLE.get(object_type) or _build(object_type)


def _build(t: str) -> Affordances:
    base = t.removesuffix("Sliced")
    return Affordances(
        pickupable=t in PICKUPABLE or t.endswith("Sliced"),
        receptacle=t in RECEPTACLE,
        openable=t in OPENABLE,
        toggleable=t in TOGGLEABLE,
        sliceable=t in SLICEABLE,
        dirtyable=t in DIRTYABLE,
        canFillWithLiquid=t in FILLABLE,
        breakable=t in BREAKABLE,
        moveable=t in MOVEABLE,
        cookable=t in COOKABLE or (t.endswith("Sliced") and base in COOKABLE),
        capacity=CAPACITY.get(t, 3 if t in RECEPTACLE else 0),
        height=HEIGHT.get(t, 0.12),
        footprint=FOOTPRINT.get(t, 0.0),
    )


_ALL = PICKUPABLE | RECEPTACLE | OPENABLE | TOGGLEABLE | SLICEABLE | DIRTYABLE | FILLABLE
_TABLE = {t: _build(t) for t in _ALL | MOVEABLE | BREAKABLE | COOKABLE}
#: Every object type with affordances of its own (a slice piece's are its whole's:
#: `slice_pieces`).
TYPES = frozenset(_TABLE)

# Pieces created by SliceObject, per sliceable type (AI2-THOR numbers its pieces from 0).
SLICE_PIECES = {"Apple": 3, "Bread": 4, "Lettuce": 3, "Potato": 3, "Tomato": 3}


def slice_pieces(object_type: str) -> tuple[str, int]:
    """The type, and how many, of the pieces that slicing an object of `object_type` gives."""
    return f"{object_type}Sliced", SLICE_PIECES.get(object_type, 2)
