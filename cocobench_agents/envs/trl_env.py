"""TRL's environment contract (`GRPOTrainer(environment_factory=…)`): an LLM policy plays one
seat of CoCoBench through tool calls, so it can be trained with GRPO.

TRL constructs the class without arguments, calls `reset(**example)` before each rollout
(its string is appended to the last user message), offers every public function of the class
but `reset` and `get_reward` to the model as a tool (its schema read from the type hints and the
docstring's ``Args:``), turns an exception a tool raises into an ``{"error": …}`` reply the
model reads, and scores the rollout with `get_reward()`. A configured class comes from
`trl_environment(source, condition=…, seat=…, partner=…)`.

TRL counts tool results against ``max_completion_length`` and ends a rollout's tool loop
when one would overflow it, so a tool returns what changed since the last call (the calls
that landed, the prompt's lines that are new, the menu ids that went), not the whole next
prompt: on D1_blind a whole prompt is ~800 tokens, an episode's results ~18,000, its changes
~1,500 (docs/environments.md).
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from typing import Any, ClassVar

from benchmark_adapter.vocabulary import BLIND, DEMO_SUITE
from cocobench_agents.conditions import condition_name
from cocobench_agents.envs.seat_env import SeatEnv
from cocobench_agents.envs.seated import DONE, EnvError
from cocobench_agents.graphs import DEFAULT_PLANNER, planner_spec
from cocobench_agents.graphs.registry import LEADER_SEAT, TEAM_SEAT
from cocobench_agents.prompts import DEFAULT_SUITE

#: What `reset` puts before the seat's first prompt, which TRL appends to the dataset's prompt.
SEPARATOR = "\n\n"
#: A line of the prompt's recent-actions list ("  3. Find(agent_1, Pen|…) -> ok"): renumbered
#: as the list slides, so its calls are reported once, as landed, not as changed lines.
HISTORY_LINE = re.compile(r"\s*\d+\. (.*)")


class CoCoBenchTRLEnv:
    """One seat of a CoCoBench episode, played through tools; the rest of the team is the
    `partner` model. Configure it with `trl_environment` (the class attributes below are its
    settings; the defaults play C0 on the built-in demo suite against `greedy`)."""

    source: ClassVar[str] = DEMO_SUITE
    condition: ClassVar[str] = condition_name(planner_spec(DEFAULT_PLANNER).code, BLIND)
    seat: ClassVar[str] = TEAM_SEAT
    partner: ClassVar[str] = "greedy"
    task_id: ClassVar[str | None] = None
    prompt_suite: ClassVar[str] = DEFAULT_SUITE
    reward_weights: ClassVar[Mapping[str, float] | None] = None
    #: `SeatEnv`'s other options (``off_menu``, ``max_steps``, ``text``, ``model_settings``…).
    env_options: ClassVar[Mapping[str, Any]] = {}

    def __init__(self) -> None:
        if self.seat == LEADER_SEAT:
            raise EnvError("the TRL environment plays the team's seat or a robot's, not the "
                           "leader's (its move is a message, not a menu id)")
        self._env = SeatEnv(self.source, condition=self.condition, seat=self.seat,
                            partner=self.partner, task_id=self.task_id,
                            prompt_suite=self.prompt_suite, reward=self.reward_weights,
                            **self.env_options)
        self._return = 0.0
        self._ended = True
        self._mask: Any = None  # the current decision's action mask
        self._lines: set[str] = set()  # the prompt's lines at the last call
        self._landed = 0  # how many of the seat's history entries were reported

    def reset(self, **example: Any) -> str:
        """Start an episode (on the instance an example's ``task_id`` names, else one drawn
        with its ``seed``); the seat's first prompt, exactly as the harness renders it."""
        options = {"task_id": example["task_id"]} if example.get("task_id") else None
        observation, _ = self._env.reset(seed=example.get("seed"), options=options)
        self._return, self._ended = 0.0, False
        self._mask = observation["action_mask"]
        prompt = self._episode.prompt_text(self.seat)
        self._lines, self._landed = set(prompt.splitlines()), len(self._history())
        # TRL appends this to the dataset's last user message: a blank line between them.
        return SEPARATOR + prompt

    def act(self, action_id: int, message: str = "") -> str:
        """Take one action: the id of an entry of the action list in the prompt.

        Args:
            action_id: The id of the chosen action, as the prompt's action list shows it.
            message: A one-line message to the teammates (only where the prompt offers a
                message board; leave empty otherwise).

        Returns:
            What changed: the calls that landed, the prompt's new lines, the menu ids gone;
            or how the episode ended.
        """
        return self._step(action_id, message)

    def done(self) -> str:
        """Declare that this robot (or the team) has nothing more to do.

        Returns:
            What changed: the calls that landed, the prompt's new lines, the menu ids gone;
            or how the episode ended.
        """
        return self._step(DONE, "")

    def get_reward(self) -> float:
        """The rollout's return: the sum of the benchmark's weighted rewards so far."""
        return self._return

    # A property, not a method: TRL offers every function of the class as a tool, and a
    # model must not be able to close its own environment (TRL lists them on the class,
    # where a property is not a function).
    @property
    def close(self) -> Callable[[], None]:
        """Close the seat's environment (its partners' event loop and connections); a later
        `reset` starts afresh. TRL never calls it: the environment also closes itself when
        an episode ends. Call ``env.close()`` when done with an instance outside TRL."""
        return self._env.close

    @property
    def _episode(self) -> Any:
        return self._env.team._live()

    def _history(self) -> list[str]:
        """The seat's landed calls, oldest first ("call -> ok" / "call -> FAIL(…)"); the
        team's seat sees every robot's."""
        return self._episode.history(self.seat)

    def _changes(self, off_menu_ids: set[int]) -> str:
        """What the seat's prompt says now that it did not at the last call."""
        history = self._history()
        landed = history[self._landed:] if len(history) >= self._landed else history
        prompt = self._episode.prompt_text(self.seat)
        lines = prompt.splitlines()
        seen_calls = set(history)
        menu = {line.strip() for line in self._episode.tools.menu_lines(
            None if self.seat == TEAM_SEAT else self.seat)}
        changed: list[str] = []
        new_menu: list[str] = []
        for line in lines:
            if not line.strip() or line in self._lines:
                continue
            entry = HISTORY_LINE.fullmatch(line)
            if entry and entry.group(1) in seen_calls:
                continue  # reported as landed
            (new_menu if line.strip() in menu else changed).append(line.strip())
        self._lines, self._landed = set(lines), len(history)
        parts = [f"Landed: {call}" for call in landed] or ["Landed: nothing"]
        if changed:
            parts.append("Changed:\n" + "\n".join(f"  {line}" for line in changed))
        if new_menu:
            parts.append("New on your menu:\n" + "\n".join(f"  {line}" for line in new_menu))
        if off_menu_ids:
            parts.append("Off your menu now: " + ", ".join(map(str, sorted(off_menu_ids))))
        if not (changed or new_menu or off_menu_ids):
            parts.append("Nothing else changed.")  # (the menu neither)
        return "\n".join(parts)

    def _step(self, action_id: int, message: str) -> str:
        if self._ended:
            raise EnvError("the episode has ended: no more actions")
        action_id = int(action_id)
        off_menu = not 0 <= action_id + 1 < len(self._mask) or not self._mask[action_id + 1]
        observation, reward, terminated, truncated, info = self._env.step(
            {"action": action_id, "message": message})
        self._return += float(reward)
        note = (f"Action {action_id} was not on the action list: it counted as an invalid "
                "choice.\n\n" if off_menu else "")
        if terminated or truncated:
            self._ended = True
            # TRL never closes its environments: the partners' loop and connections go now.
            self._env.close()
            return (f"{note}The episode has ended ({info['terminal_reason']}): task success "
                    f"{info['task_success']}, goal progress {info['task_progress']}.")
        before = set(map(int, self._mask.nonzero()[0]))
        self._mask = observation["action_mask"]
        gone = {i + DONE for i in before - set(map(int, self._mask.nonzero()[0]))}
        return note + self._changes(gone)


def trl_environment(source: str, *, condition: str, seat: str, partner: str = "greedy",
                    task_id: str | None = None, prompt_suite: str = DEFAULT_SUITE,
                    reward: Mapping[str, float] | None = None, **options: Any
                    ) -> type[CoCoBenchTRLEnv]:
    """A `CoCoBenchTRLEnv` class with these settings, checked by building one instance: pass
    it as ``GRPOTrainer(environment_factory=…)``. `options` are `SeatEnv`'s (``off_menu``,
    ``max_steps``, ``text``, ``model_settings``, …)."""
    settings = {"source": source, "condition": condition, "seat": seat, "partner": partner,
                "task_id": task_id, "prompt_suite": prompt_suite, "reward_weights": reward,
                "env_options": dict(options)}
    configured = type("CoCoBenchTRLEnv", (CoCoBenchTRLEnv,), settings)
    configured()  # bad settings fail here, not in the trainer
    return configured
