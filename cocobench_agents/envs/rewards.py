"""The environment's rewards: the benchmark's own measures, weighted by the caller.

* ``progress``: the change in the fraction of goal checks passing (the result line's
  ``task_progress`` as the episode goes), shared by every seat, each step;
* ``legality``: minus one for each of the seat's own landed calls that failed in the simulator
  (the C0 planner answers for every call; the leader lands none);
* ``success``: the result line's ``task_success`` (after the legality gate), at the end;
* ``construct``: the result line's ``construct_score`` (0 when it has none), at the end.
"""

from __future__ import annotations

from collections.abc import Mapping

from benchmark_adapter.metrics import EpisodeResult
from cocobench_agents.envs.seated import EnvError

#: The default weights: progress and success count fully, a failed call costs a tenth.
DEFAULT_WEIGHTS: dict[str, float] = {"progress": 1.0, "success": 1.0, "legality": 0.1,
                                     "construct": 0.0}


def reward_weights(reward: Mapping[str, float] | None) -> dict[str, float]:
    """`DEFAULT_WEIGHTS` with the caller's weights; an unknown name is an `EnvError`."""
    weights = dict(DEFAULT_WEIGHTS)
    for name, weight in (reward or {}).items():
        if name not in DEFAULT_WEIGHTS:
            raise EnvError(f"unknown reward {name!r}: the rewards are "
                           f"{', '.join(DEFAULT_WEIGHTS)}")
        if not isinstance(weight, (int, float)) or isinstance(weight, bool):
            raise EnvError(f"the weight of reward {name!r} must be a number, not {weight!r}")
        weights[name] = float(weight)
    return weights


def step_reward(weights: Mapping[str, float], *, progress_gain: float, failed_calls: int,
                result: EpisodeResult | None) -> float:
    """One seat's reward for one step (`result`: the scored episode, on its last step)."""
    reward = weights["progress"] * progress_gain - weights["legality"] * failed_calls
    if result is not None:
        reward += weights["success"] * result.task_success
        reward += weights["construct"] * (result.construct_score or 0.0)
    return reward
