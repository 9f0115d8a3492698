"""The embedded simulator: a deterministic symbolic household world grounded from a task config."""

from benchmark_adapter.sim.embedded.controller import EmbeddedController
from benchmark_adapter.sim.embedded.thor_compat import ThorCompatController

__all__ = ["EmbeddedController", "ThorCompatController"]
