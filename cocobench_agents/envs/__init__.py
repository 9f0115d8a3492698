"""CoCoBench for training: the benchmark as a PettingZoo environment (`parallel_env`, `env`),
a single-learner Gymnasium environment (`SeatEnv`) and TRL's environment contract
(`trl_environment`, `CoCoBenchTRLEnv`). They need the ``env`` extra (``pip install -e
'.[env]'``); see docs/environments.md.

Names load on first use (PEP 562): `SeatedEpisode` (the episode stepped by actions, on the
planners' own rules) needs neither Gymnasium nor PettingZoo.
"""

from __future__ import annotations

from cocobench_agents.lazy import lazy_getattr

_EXPORTS = {
    "CoCoBenchParallelEnv": ".parallel", "env": ".parallel", "parallel_env": ".parallel",
    "DEFAULT_WEIGHTS": ".rewards",
    "SeatEnv": ".seat_env",
    "DONE": ".seated", "EnvError": ".seated", "SeatAction": ".seated",
    "SeatedEpisode": ".seated",
    "CoCoBenchTRLEnv": ".trl_env", "trl_environment": ".trl_env",
}
__all__ = sorted(_EXPORTS)

__getattr__ = lazy_getattr(__name__, _EXPORTS)
