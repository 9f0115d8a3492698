"""The training reward's default weights and its formula, shared by the environments
(`envs.rewards`, which documents each term) and the export's per-decision ``reward`` column
(`export.decisions`): offline data rewarded as the environments reward online play."""

from __future__ import annotations

from collections.abc import Mapping

from benchmark_adapter.metrics import EpisodeResult

#: The default weights: progress and success count fully, the construct score half, a failed
#: call or an invalid id 0.002.
DEFAULT_WEIGHTS: dict[str, float] = {"progress": 1.0, "success": 1.0, "legality": 0.002,
                                     "construct": 0.5}


def step_reward(weights: Mapping[str, float], *, progress_gain: float, failed_calls: int,
                result: EpisodeResult | None) -> float:
    """One seat's reward for one step (`result`: the scored episode, on its last step)."""
    reward = weights["progress"] * progress_gain - weights["legality"] * failed_calls
    if result is not None:
        reward += end_reward(weights, result.task_success, result.construct_score)
    return reward


def end_reward(weights: Mapping[str, float], success: bool | int, construct: float | None
               ) -> float:
    """What the episode's end pays: success, and the construct score of a success."""
    return (weights["success"] * success
            + weights["construct"] * (construct or 0.0) * success)
