"""Simulator backends behind one `Controller` protocol."""

from benchmark_adapter.sim.protocol import Controller, Metadata

__all__ = ["Controller", "Metadata"]
