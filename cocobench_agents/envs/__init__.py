"""CoCoBench for training: the benchmark as a PettingZoo environment (`parallel_env`, `env`),
a single-learner Gymnasium environment (`SeatEnv`) and TRL's environment contract
(`trl_environment`, `CoCoBenchTRLEnv`). They need the ``env`` extra (``pip install -e
'.[env]'``); see docs/environments.md.

Importing it registers `SeatEnv` with Gymnasium as ``CoCoBench/Seat-v0`` (where Gymnasium is
installed). Names load on first use (PEP 562): `SeatedEpisode` (the episode stepped by
actions, on the planners' own rules) needs neither Gymnasium nor PettingZoo.
"""

from __future__ import annotations

import importlib.util

from cocobench_agents.lazy import lazy_getattr

_EXPORTS = {
    "CoCoBenchParallelEnv": ".parallel", "env": ".parallel", "parallel_env": ".parallel",
    "DEFAULT_WEIGHTS": ".rewards",
    "SeatEnv": ".seat_env",
    "DONE": ".seated", "EnvError": ".seated", "EnvWarning": ".seated", "SeatAction": ".seated",
    "SeatedEpisode": ".seated",
    "CoCoBenchTRLEnv": ".trl_env", "trl_environment": ".trl_env",
}
__all__ = sorted([*_EXPORTS, "SEAT_ENV_ID"])

__getattr__ = lazy_getattr(__name__, _EXPORTS)

#: The Gymnasium id of `SeatEnv`: ``gymnasium.make(SEAT_ENV_ID, source=…, condition=…, seat=…,
#: partner=…, render_mode=…)``.
SEAT_ENV_ID = "CoCoBench/Seat-v0"


def _register() -> None:
    """Register `SEAT_ENV_ID` with Gymnasium where it is installed (the entry point is a
    string: nothing of the environment loads until `gymnasium.make`)."""
    if importlib.util.find_spec("gymnasium") is None:
        return
    import gymnasium

    if SEAT_ENV_ID not in gymnasium.registry:
        gymnasium.register(SEAT_ENV_ID, entry_point="cocobench_agents.envs.seat_env:SeatEnv")


_register()
