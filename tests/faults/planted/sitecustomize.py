"""Planted faults for the "no exception can hang a run" tests (issue 34): with this folder on
PYTHONPATH and ``COCOBENCH_PLANTED_FAULT`` naming a phase of an episode, every process of the
run (the command, forked workers, Ray's workers) raises `PlantedFault` in that phase, in every
episode. The target module is patched right after it is imported, so a process that never
imports it (Ray's own helpers) pays nothing.

Phases: ``reply`` (the model's answer), ``parse`` (reading it), ``step`` (the simulator),
``score`` (scoring the trajectory), ``write`` (writing the trajectory: the run folder refuses
the text, as it refused a reply's lone surrogate). And ``silent``: a worker's episode never
ends nor reports (as a task that died without a word), and the supervisor's grace past
``--episode-timeout`` is half a second.
"""

from __future__ import annotations

import importlib.abc
import importlib.machinery
import os
import sys
from typing import Any

VARIABLE = "COCOBENCH_PLANTED_FAULT"
#: phase → (module, attribute path) of what raises.
TARGETS = {
    "reply": ("cocobench_agents.models.builtin", "GreedyClient.complete"),
    "parse": ("cocobench_agents.graphs.decision", "parse_reply"),
    "step": ("benchmark_adapter.episode", "Episode.step"),
    "score": ("cocobench_agents.tools.episode_tools", "score_trajectory"),
    "write": ("cocobench_agents.runfolder.folder", "RunFolder.write_trajectory"),
}


SILENT = "silent"
SILENT_GRACE_S = 0.5


async def _never_reports(*args: Any, **kwargs: Any) -> Any:
    import asyncio

    await asyncio.Event().wait()


#: module → (attribute, value) of the ``silent`` phase.
SILENT_PATCHES = {
    "cocobench_agents.harness.workers": [("run_one", _never_reports),
                                         ("OVERDUE_GRACE_S", SILENT_GRACE_S)],
    "cocobench_agents.harness.ray_worker": [("run_one", _never_reports)],
    "cocobench_agents.harness.ray_executor": [("OVERDUE_GRACE_S", SILENT_GRACE_S)],
}


class PlantedFault(RuntimeError):
    """What a planted phase raises."""


def fault(phase: str) -> Any:
    def raises(*args: Any, **kwargs: Any) -> Any:
        if phase == "write":  # what writing a reply's lone surrogate raised
            raise UnicodeEncodeError("utf-8", "\ud800", 0, 1, "surrogates not allowed")
        raise PlantedFault(f"planted in {phase}")

    if phase == "reply":  # an async method
        async def replies(*args: Any, **kwargs: Any) -> Any:
            return raises()
        return replies
    return raises


def target(module: Any, attribute: str) -> tuple[Any, str]:
    """The object that holds what a phase patches, and its name there."""
    owner_name, _, name = attribute.rpartition(".")
    return (getattr(module, owner_name) if owner_name else module), name


def _patch(module: Any, phase: str) -> None:
    if phase == SILENT:
        for attribute, value in SILENT_PATCHES[module.__name__]:
            setattr(module, attribute, value)
    else:
        setattr(*target(module, TARGETS[phase][1]), fault(phase))


class _PatchAfterImport(importlib.abc.MetaPathFinder):
    """Finds the target module as usual, and patches it once it has run."""

    def __init__(self, module: str, phase: str) -> None:
        self.module, self.phase = module, phase

    def find_spec(self, fullname: str, path: Any, target: Any = None) -> Any:
        if fullname != self.module:
            return None
        spec = importlib.machinery.PathFinder.find_spec(fullname, path)
        if spec is None or spec.loader is None:
            return None
        run_module = spec.loader.exec_module

        def exec_module(module: Any) -> None:
            run_module(module)
            _patch(module, self.phase)

        spec.loader.exec_module = exec_module  # type: ignore[method-assign]
        return spec


def _install() -> None:
    phase = os.environ.get(VARIABLE)
    if not phase:
        return
    modules = list(SILENT_PATCHES) if phase == SILENT else [TARGETS[phase][0]]
    for module in modules:
        if module in sys.modules:
            _patch(sys.modules[module], phase)
        else:
            sys.meta_path.insert(0, _PatchAfterImport(module, phase))


_install()
