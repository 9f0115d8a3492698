"""The embedded simulator: a deterministic symbolic household world grounded from a task config."""

from benchmark_adapter.sim.embedded.controller import EmbeddedController

__all__ = ["EmbeddedController"]
