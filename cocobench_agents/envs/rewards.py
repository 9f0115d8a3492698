"""The environment's rewards: the benchmark's own measures, weighted by the caller.

* ``progress``: the change in the fraction of goal checks passing (the result line's
  ``task_progress`` as the episode goes), shared by every seat, each step. It is
  potential-based shaping (Φ = the fraction passing, γ = 1): an episode's progress rewards
  sum to its final progress, so undoing and redoing a check earns nothing;
* ``legality``: minus one for each of the seat's own landed calls that failed in the simulator
  and each of its choices off the menu (an invalid id; the C0 planner answers for every call;
  the leader lands none);
* ``success``: the result line's ``task_success`` (after the legality gate), at the end;
* ``construct``: the result line's ``construct_score`` of a successful episode (0 when it
  has none or failed), at the end. Gated by success because aimless play scores too: random
  moves under C0 scored 0.30 on average on 40 held-out instances of cocobench-240 (1.0 on 6)
  while making 0.015 progress, so an ungated construct reward would pay for wandering.

The defaults make doing nothing a poor policy rather than the best one: a failed call costs
0.002, a hundredth of the least a passing check is worth (1/5: no instance has more than five
checks), so exploring pays once it makes progress (random play fails ~14 calls an episode: at
0.1 that cost 200 times its progress, at 0.01 a learner settled on `find`, which never fails,
progress 0); an invalid id costs what a failed call does and does what DONE does (ends a C0
episode, idles a robot for its round), so it is never better than a legal choice.
"""

from __future__ import annotations

from collections.abc import Mapping

from cocobench_agents.envs.seated import EnvError
from cocobench_agents.rewards import DEFAULT_WEIGHTS, step_reward

__all__ = ["DEFAULT_WEIGHTS", "reward_weights", "step_reward"]


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
