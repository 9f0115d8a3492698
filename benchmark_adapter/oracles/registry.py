"""Which oracle plan runs a config: the released cell plans plus plans registered by name.

A config may name its plan in `provenance.oracle` (the instance generator writes it); without
a name, the config's cell picks its released plan from `ORACLE_PLANS`. Plans beyond the
released cells are added with `register_plan`. The modules in `PLAN_PROVIDERS` register theirs
when imported, and are imported on the first lookup of an unknown name, so a config naming a
generator plan runs without its caller importing the generator first.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable

from benchmark_adapter.oracles.plans import ORACLE_PLANS, Plan
from benchmark_adapter.tasks.config import TaskConfig

PlanFunction = Callable[[TaskConfig], Plan]

# Modules that call `register_plan` at import time.
PLAN_PROVIDERS: tuple[str, ...] = ("benchmark_adapter.generator.oracles",)

_REGISTERED: dict[str, PlanFunction] = {}
_providers_loaded = False


def register_plan(name: str, plan: PlanFunction) -> None:
    """Make `plan` available to configs whose `provenance.oracle` is `name`.

    Released cell keys cannot be overridden (their plans define the reference behaviour);
    registering the same function twice is harmless.
    """
    if name in ORACLE_PLANS:
        raise ValueError(f"oracle plan {name!r} is a released cell plan and cannot be replaced")
    known = _REGISTERED.get(name)
    if known is not None and known is not plan:
        raise ValueError(f"oracle plan {name!r} is already registered to {known.__qualname__}")
    _REGISTERED[name] = plan


def registered_plans() -> dict[str, PlanFunction]:
    """Every plan a config can name: released cells and registered plans."""
    _load_providers()
    return {**ORACLE_PLANS, **_REGISTERED}


def plan_name(config: TaskConfig) -> str:
    """The name of the plan a config runs: `provenance.oracle`, else its cell."""
    named = config.provenance.get("oracle")
    return named if isinstance(named, str) and named else config.cell


def plan_function(config: TaskConfig) -> PlanFunction | None:
    """The plan function for a config, or None when nothing is registered under its name."""
    name = plan_name(config)
    if name in ORACLE_PLANS:
        return ORACLE_PLANS[name]
    if name not in _REGISTERED:
        _load_providers()
    return _REGISTERED.get(name)


def _load_providers() -> None:
    global _providers_loaded
    if _providers_loaded:
        return
    _providers_loaded = True
    for module in PLAN_PROVIDERS:
        importlib.import_module(module)
