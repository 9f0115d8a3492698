"""Condition names: a planner's code under an observation mode, ``<code>_<mode>`` (`C0_image`),
as run folders, result lines and reports name them. Written and read here only; the codes are
the planners' own (`graphs`: `PlannerSpec.code`), the modes the benchmark's
(`benchmark_adapter.vocabulary`).
"""

from __future__ import annotations

from benchmark_adapter.vocabulary import OBSERVATION_MODES

#: Between a condition's code and its observation mode.
SEPARATOR = "_"


def condition_name(code: str, obs_mode: str) -> str:
    """`C0`, `image` -> `C0_image`."""
    return f"{code}{SEPARATOR}{obs_mode}"


def split_condition(condition: str) -> tuple[str, str]:
    """`C0_image` -> ("C0", "image"); a name without an observation mode -> (name, "")."""
    head, sep, tail = condition.rpartition(SEPARATOR)
    if sep and head and tail in OBSERVATION_MODES:
        return head, tail
    return condition, ""


def obs_mode_rank(mode: str) -> int:
    """Where a mode sorts: in `OBSERVATION_MODES`' order, an unknown one (or none) after."""
    return OBSERVATION_MODES.index(mode) if mode in OBSERVATION_MODES else len(OBSERVATION_MODES)
