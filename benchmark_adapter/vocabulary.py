"""Words several layers of the benchmark share, kept at the bottom so that each imports them
downwards: task checks (`tasks`) name skills the executor (`skills`) implements, and the
simulator (`sim`) grounds the affordances the menu (`menu`) is built from.
"""

#: The high-level skills a task may allow; `skills.SKILLS` implements each, in this order.
SKILL_NAMES: tuple[str, ...] = (
    "Find",
    "Explore",
    "Wait",
    "PickUp",
    "Put",
    "Drop",
    "Open",
    "Close",
    "ToggleOn",
    "ToggleOff",
    "Slice",
    "CleanObject",
    "FillObjectWithLiquid",
    "EmptyLiquidFromObject",
    "PushObject",
    "PullObject",
    "BreakObject",
)

#: The object-metadata flags that put an object in the action menu.
AFFORDANCE_FLAGS: tuple[str, ...] = (
    "pickupable",
    "receptacle",
    "openable",
    "toggleable",
    "sliceable",
    "dirtyable",
    "canFillWithLiquid",
    "breakable",
    "moveable",
)
