"""Words several layers of the benchmark share, kept at the bottom so that each imports them
downwards: task checks (`tasks`) name skills the executor (`skills`) implements, and the
simulator (`sim`) grounds the affordances the menu (`menu`) is built from; and the words the
agents' side shares with the benchmark, each spelled here and nowhere else
(tests/test_vocabulary.py): observation modes, coordination dimensions, backend names and the
built-in suites.

Each word set is a `Literal` type with a constant per word and a tuple of all of them, so the
values stay the plain strings that run folders, results and prompts hold: a ``(str, Enum)``
member prints as ``ObservationMode.IMAGE``, `StrEnum` needs Python 3.11, and either would
change the request's JSON schema. Adding a word is a change here plus the code that gives it
meaning (a template, a metric), which tests/test_vocabulary.py names.
"""

from __future__ import annotations

from typing import Literal, get_args

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

#: What a planner's model sees each step besides the text: ``image`` sends the rendered
#: frames, ``blind`` none. A mode needs its view templates (`prompts/fields.py`).
ObservationMode = Literal["image", "blind"]
IMAGE: ObservationMode = "image"
BLIND: ObservationMode = "blind"
#: Every observation mode, in the order runs plan them and reports list them.
OBSERVATION_MODES: tuple[ObservationMode, ...] = get_args(ObservationMode)

#: The coordination dimensions a task exercises (its ``coordination_dim``), each with its
#: construct score (`metrics/constructs.py`).
Dimension = Literal["D1", "D2", "D3", "D4"]
LOAD_BALANCING: Dimension = "D1"
PRECEDENCE: Dimension = "D2"
MUTUAL_EXCLUSION: Dimension = "D3"
PRODUCER_CONSUMER: Dimension = "D4"
#: Every dimension, in report order.
DIMENSIONS: tuple[Dimension, ...] = get_args(Dimension)

#: The simulators an episode runs on (`sim/backends.py` makes each one's controller).
Backend = Literal["embedded", "ai2thor"]
EMBEDDED: Backend = "embedded"
AI2THOR: Backend = "ai2thor"
BACKEND_NAMES: tuple[Backend, ...] = get_args(Backend)
DEFAULT_BACKEND: Backend = EMBEDDED

#: The task suites shipped as folders under ``benchmark_adapter/data/``.
BuiltinSuite = Literal["cocobench-240", "cocobench-full", "demo"]
SUBSET_SUITE: BuiltinSuite = "cocobench-240"  # the paper's representative 240 instances
FULL_SUITE: BuiltinSuite = "cocobench-full"  # all the generated instances
DEMO_SUITE: BuiltinSuite = "demo"  # four small instances, one per dimension
BUILTIN_SUITES: tuple[BuiltinSuite, ...] = get_args(BuiltinSuite)
#: The instances a run plays when it names none.
DEFAULT_TASKS: BuiltinSuite = SUBSET_SUITE
