"""`SeatEnv`: one seat learns; the condition's other seats are played by a model the harness
runs (a frozen partner)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, ClassVar

import gymnasium

from cocobench_agents.envs.parallel import (
    RENDER_MODES,
    CoCoBenchParallelEnv,
    _seats_of,
    check_seed,
    side_by_side,
    text_view,
)
from cocobench_agents.envs.seated import EnvError
from cocobench_agents.graphs.registry import LEADER_SEAT, TEAM_SEAT
from cocobench_agents.prompts import DEFAULT_SUITE


class SeatEnv(gymnasium.Env):
    """CoCoBench as a Gymnasium environment for one `seat` of `condition` (``team`` for C0,
    a robot such as ``agent_0``, or ``leader``); every other seat is played by `partner`, a
    model spec (``greedy``, ``random``, ``scripted:FILE``, ``replay:RUN``, a LiteLLM model).
    Spaces, rewards and options are `parallel_env`'s (docs/environments.md)."""

    metadata: ClassVar[dict[str, Any]] = {"render_modes": list(RENDER_MODES), "render_fps": 4}

    def __init__(self, source: str, *, condition: str, seat: str, partner: str,
                 task_id: str | None = None, prompt_suite: str = DEFAULT_SUITE,
                 reward: Mapping[str, float] | None = None, seed: int | None = None,
                 render_mode: str | None = None, **options: Any) -> None:
        self.team = CoCoBenchParallelEnv(source, condition=condition, task_id=task_id,
                                         prompt_suite=prompt_suite, reward=reward, seed=seed,
                                         partners={}, render_mode=render_mode, **options)
        self.render_mode = render_mode
        planner = self.team.condition.planner
        for config in self.team.configs:
            seats = _seats_of(config, planner)
            if seat not in seats:
                raise EnvError(f"no seat {seat!r} in {config.task_id} under {condition}: its "
                               f"seats are {', '.join(seats)}")
        self.seat = seat
        self.team.set_partners({s: partner for s in self.team.possible_agents if s != seat})
        self.observation_space = self.team.observation_space(seat)
        self.action_space = self.team.action_space(seat)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        check_seed(seed)  # (before Gymnasium's own error)
        super().reset(seed=seed)
        observations, infos = self.team.reset(seed=seed, options=options)
        return observations[self.seat], infos[self.seat]

    def step(self, action: Any):
        observations, rewards, terminations, truncations, infos = self.team.step(
            {self.seat: action})
        return (observations[self.seat], rewards[self.seat], terminations[self.seat],
                truncations[self.seat], infos[self.seat])

    def render(self) -> str | Any | None:
        """The seat's view as `render_mode` says: ``"ansi"``, its prompt (its menu lines when
        ``text=False``); ``"rgb_array"``, its camera frame (the team's seat and the leader:
        every robot's, side by side); None without a render mode."""
        if self.render_mode is None:
            return None
        episode = self.team._live()
        if self.render_mode == "ansi":
            return text_view(episode, self.seat)
        agents = (episode.spec.config.agent_ids if self.seat in (TEAM_SEAT, LEADER_SEAT)
                  else [self.seat])
        return side_by_side([episode.episode.frame(a) for a in agents])

    def close(self) -> None:
        self.team.close()

    @property
    def result(self):
        """The ended episode's scored result (None before its end)."""
        return self.team.state_result

