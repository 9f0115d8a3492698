"""What Inspect's ``inspect_ai`` entry point loads: the task, registered as
``cocobench_agents/cocobench``."""

from .task import cocobench

__all__ = ["cocobench"]
