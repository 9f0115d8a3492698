"""The PettingZoo environment: every seat of a condition learns (`parallel_env`, `env`)."""

from __future__ import annotations

import asyncio
import warnings
import weakref
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv
from pettingzoo.utils.conversions import parallel_to_aec

from benchmark_adapter.menu_bound import largest_action_id
from benchmark_adapter.tasks import TaskConfig
from benchmark_adapter.vocabulary import IMAGE
from cocobench_agents.envs.features import NumericLayout, WorldFeatures, check_observation
from cocobench_agents.envs.rewards import reward_weights, step_reward
from cocobench_agents.envs.seated import (
    DONE,
    EnvError,
    EnvWarning,
    SeatAction,
    SeatedEpisode,
    check_off_menu,
    close_loop,
    close_quietly,
    partner_settings,
    seat_name,
)
from cocobench_agents.envs.source import instances, one_condition
from cocobench_agents.envs.spaces import SeatSpaces
from cocobench_agents.envs.turns import new_loop
from cocobench_agents.episode_runner import DEFAULT_MODEL_KEY, EpisodeSpec
from cocobench_agents.graphs import ORACLE, planner_spec
from cocobench_agents.graphs.registry import AGENT_SEAT, LEADER_SEAT, TEAM_SEAT
from cocobench_agents.models import ModelPool
from cocobench_agents.models.settings import ModelSettings
from cocobench_agents.prompts import DEFAULT_SUITE

#: The model name the learning seats' decisions and the result line record by default.
DEFAULT_MODEL_NAME = "env"
#: What `render()` returns: the seats' text view, or their camera frames as one RGB array.
RENDER_MODES = ("ansi", "rgb_array")
#: The options `reset(options=…)` reads.
RESET_OPTIONS = ("task_id",)
#: How many instances' episodes an environment keeps built, the most recently played: one
#: builds in about a millisecond but holds about 0.8 MB (all 897 of cocobench-full held 1 GB).
KEPT_EPISODES = 32


class CoCoBenchParallelEnv(ParallelEnv):
    """CoCoBench as a PettingZoo `ParallelEnv`: the agents are the seats of `condition`
    (``team`` for C0; one per robot for D0/D1; ``leader`` and one per robot for
    leader–worker, whose rounds take two steps: the leader's, then the robots'). See
    docs/environments.md."""

    metadata: ClassVar[dict[str, Any]] = {"name": "cocobench_v0",
                                          "render_modes": list(RENDER_MODES), "render_fps": 4,
                                          "is_parallelizable": True}

    def __init__(self, source: str, *, condition: str, task_id: str | None = None,
                 prompt_suite: str = DEFAULT_SUITE, reward: Mapping[str, float] | None = None,
                 seed: int | None = None, text: bool = True, max_steps: int | None = None,
                 max_menu: int | None = None, model: str = DEFAULT_MODEL_NAME,
                 partners: Mapping[str, str] | None = None, off_menu: str = "score",
                 model_settings: ModelSettings | Mapping[str, Any] | None = None,
                 render_mode: str | None = None, observation: str = "text") -> None:
        check_off_menu(off_menu)
        check_seed(seed)
        check_max_steps(max_steps)
        check_render_mode(render_mode)
        check_observation(observation)
        check_flag("text", text)
        self.condition = one_condition(condition)
        self.configs = instances(source, task_id)
        self.weights = reward_weights(reward)
        self.prompt_suite, self.text, self.max_steps = prompt_suite, text, max_steps
        self.model, self.off_menu = model, off_menu
        self._max_menu = checked_max_menu(self.configs, max_menu)
        #: The numeric tables' maker under ``observation="numeric"`` (`features.py`).
        self.numeric = (WorldFeatures(NumericLayout.of(self.configs, self._max_menu))
                        if observation == "numeric" else None)
        self.pool = ModelPool(partner_settings(model_settings))
        #: The one event loop the episodes' partner calls run on (made with the first episode).
        self.loop: asyncio.AbstractEventLoop | None = None
        self.render_mode = render_mode
        self.possible_agents = _all_seats(self.configs, self.condition.planner)
        self._frame = _frame_shape(self.configs[0]) if self.condition.obs_mode == IMAGE else None
        self._episodes: dict[str, SeatedEpisode] = {}
        self.set_partners(partners or {})
        self._checks = max(_check_count(c) for c in self.configs)
        size = 2 + self._checks + len(self.possible_agents) * (self._max_menu + 2)
        #: `state()`'s space: a global view for centralized critics (see `state`).
        self.state_space = spaces.Box(0.0, 1.0, (size,), np.float32)
        self._rng = np.random.default_rng(seed)
        self.episode: SeatedEpisode | None = None
        self.agents: list[str] = []

    # -- PettingZoo's interface ----------------------------------------------------------

    def observation_space(self, agent: str):
        return self._seat_spaces(agent).observation  # (the same object every call)

    def action_space(self, agent: str):
        return self._seat_spaces(agent).action

    def reset(self, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[dict[str, Any], dict[str, Any]]:
        """Start an episode: the instance `options["task_id"]` names, else one drawn with
        the seeded generator (the only one when the source holds one)."""
        check_seed(seed)
        if seed is not None:
            self._rng = np.random.default_rng(seed)
        if self.episode is not None:  # its planner stopped, not left waiting on the loop
            self.episode.abandon()
        config = self._pick(reset_options(options).get("task_id"))
        made = config.task_id not in self._episodes  # (a new episode starts at once)
        self.episode = self._episode_for(config)
        if not made:
            self.episode.reset()
        self.agents = [s for s in self.episode.seats if s in self.learning]
        info = self._info()
        return self._observations(), {s: dict(info) for s in self.agents}

    def step(self, actions: Mapping[str, Any]):
        """Play one phase with the seats' `actions`."""
        episode = self._live()
        unknown = sorted(set(actions) - set(self.agents))
        if unknown:
            raise EnvError(f"no live seat {unknown[0]!r}: the seats are "
                           f"{', '.join(self.agents) or 'none (the episode has ended)'}")
        moves = {s: self._seat_spaces(s).decode(a) for s, a in actions.items()}
        before, items = episode.progress(), len(episode.episode.items)
        decisions = len(episode.tools.decisions)
        episode.step(moves)
        return self._outcome(episode, before, items, decisions)

    def state(self) -> np.ndarray:
        """A global view for centralized critics, float32 in [0, 1]: the share of the step
        budget used, the goal progress, each goal check passing (1) or not (its count that of
        the source's instance with the most; the rest 0), then each seat's action mask over
        `possible_agents` in order (DONE and the ids on its menu now, whoever plays it; a
        seat without a menu now, or absent from this instance, all 0)."""
        episode = self._live()
        checks = episode.episode.items[-1]["eval"]["checks"]
        masks = np.zeros((len(self.possible_agents), self._max_menu + 2), np.float32)
        for row, seat in enumerate(self.possible_agents):
            if seat in episode.seats and seat != LEADER_SEAT and _acts(episode, seat):
                masks[row, 0] = 1.0
                ids = [o.action_id for o in episode.tools.menu_options(
                    None if seat == TEAM_SEAT else seat)]
                masks[row, np.asarray(ids, int) - DONE] = 1.0
        passed = np.zeros(self._checks, np.float32)
        passed[:len(checks)] = [float(c["passed"]) for c in checks]
        used = min(episode.tools.step_index / episode.spec.budget, 1.0)
        return np.concatenate([[used, episode.progress()], passed, masks.ravel()]
                              ).astype(np.float32)

    def render(self) -> str | np.ndarray | None:
        """The live seats' view as `render_mode` says: ``"ansi"``, each seat's prompt (its
        menu lines when ``text=False``) under its name; ``"rgb_array"``, every robot's camera
        frame side by side; None without a render mode."""
        if self.render_mode is None:
            return None
        episode = self._live()
        if self.render_mode == "ansi":
            return "\n\n".join(f"== {seat} ==\n{text_view(episode, seat)}"
                                 for seat in self.agents or self.learning)
        return side_by_side([episode.episode.frame(a) for a in episode.spec.config.agent_ids])

    def close(self) -> None:
        """Close the partners' connections and the event loop they ran on (a later
        `reset` starts afresh); closing twice is harmless."""
        self._episodes.clear()
        if self.loop is not None:
            close_loop(self.loop, self.pool)

    def set_partners(self, partners: Mapping[str, str]) -> None:
        """Have model specs play the seats `partners` names (checked); the rest learn. Call it
        before the first `reset` (`SeatEnv` does, once it has checked its seat)."""
        unknown = sorted(set(partners) - set(self.possible_agents))
        if unknown:
            raise EnvError(f"partners name no seat {unknown[0]!r}: the seats under "
                           f"{self.condition.name} are {', '.join(self.possible_agents)}")
        self.partners = dict(partners)
        self._episodes.clear()  # built with the partners before
        for spec in dict.fromkeys(self.partners.values()):
            if spec != ORACLE:  # the reference plan, not a model (oracle_partner.py)
                self.pool.validate(spec)
        planner = planner_spec(self.condition.planner)
        self.learning = [s for s in self.possible_agents if s not in self.partners]
        robots = max(len(c.agent_ids) for c in self.configs)
        self._spaces = {seat: SeatSpaces(
            seat, max_menu=self._max_menu, broadcasts=planner.broadcast,
            image_shape=self._image_shape(seat, robots), numeric=self.numeric)
            for seat in self.learning}

    # -- internals ---------------------------------------------------------------------

    def _outcome(self, episode: SeatedEpisode, before: float, items: int, decisions: int):
        landed = episode.landed(items)
        made = episode.tools.decisions[decisions:]
        gain = episode.progress() - before
        seats = self.agents
        rewards = {s: step_reward(self.weights, progress_gain=gain,
                                  failed_calls=_failed(landed, s) + _invalid(made, s),
                                  result=episode.result)
                   for s in seats}
        truncated = episode.finished and episode.terminal_reason == "max_steps"
        terminations = dict.fromkeys(seats, episode.finished and not truncated)
        truncations = dict.fromkeys(seats, truncated)
        observations = self._observations()
        info = self._info()
        infos = {s: dict(info) for s in seats}
        if episode.finished:
            self.agents = []
        return observations, rewards, terminations, truncations, infos

    def _observations(self) -> dict[str, Any]:
        episode = self._live()
        image = episode.spec.obs_mode == IMAGE
        return {s: self._seat_spaces(s).encode(episode.view(s),
                                               self._seat_frame(s) if image else None, episode)
                for s in self.agents}

    def _seat_frame(self, seat: str) -> np.ndarray:
        """The seat's frame, a new array (each observation owns its data: Gymnasium's
        check_env): its robot's camera, or for the team's seats every robot's in its slot,
        black past this task's robots. Each pixel is written once, straight from the
        simulator's pixels (zeroing the whole array first cost a tenth of a C0 step)."""
        episode = self._live()
        out = np.empty(self._seat_spaces(seat).image_shape, np.uint8)
        if seat not in (TEAM_SEAT, LEADER_SEAT):
            return episode.episode.frame_pixels(seat, out=out)
        robots = episode.spec.config.agent_ids
        for slot, agent in zip(out, robots):
            episode.episode.frame_pixels(agent, out=slot)
        out[len(robots):] = 0
        return out

    def _info(self) -> dict[str, Any]:
        episode = self._live()
        if episode.result is not None:  # the episode's result line
            return episode.result.model_dump(mode="json")
        return {"task_id": episode.spec.config.task_id, "step_index": episode.tools.step_index,
                "phase": episode.phase, "progress": episode.progress(),
                # Partners' calls that got no answer: the harness counts such an episode as
                # an infrastructure failure (`runfolder.is_infra_failure`), not a score.
                "unanswered_calls": episode.tools.counters["backend_errors"]}

    def _live(self) -> SeatedEpisode:
        if self.episode is None:
            raise EnvError("no episode yet: call reset() first")
        return self.episode

    def _seat_spaces(self, seat: str) -> SeatSpaces:
        spaces = self._spaces.get(seat)
        if spaces is None:
            raise EnvError(f"no learning seat {seat!r}: the seats are "
                           f"{', '.join(self.learning)}")
        return spaces

    def _pick(self, task_id: str | None) -> TaskConfig:
        if task_id is not None:
            found = [c for c in self.configs if c.task_id == task_id]
            if not found:
                raise EnvError(f"unknown task_id {task_id!r} in options: the source's "
                               f"instances are {', '.join(c.task_id for c in self.configs[:4])}"
                               "…")
            return found[0]
        return self.configs[int(self._rng.integers(len(self.configs)))]

    def _episode_for(self, config: TaskConfig) -> SeatedEpisode:
        if self.loop is None or self.loop.is_closed():
            self.loop = new_loop()
            # Closed when the environment is collected or, at the latest, at interpreter
            # exit while the modules a close needs are still there (a `__del__` ran during
            # their teardown and printed "Exception ignored … EVENT_READ").
            weakref.finalize(self, close_quietly, self.loop)
        episode = self._episodes.pop(config.task_id, None)
        if episode is None:
            spec = EpisodeSpec(config, planner=self.condition.planner,
                               models={DEFAULT_MODEL_KEY: self.model},
                               obs_mode=self.condition.obs_mode,
                               prompt_suite=self.prompt_suite, max_steps=self.max_steps)
            partners = {s: c for s, c in self.partners.items()
                        if s in _seats_of(config, self.condition.planner)}
            # (The numeric observation holds no prompt: none is copied into the views.)
            episode = SeatedEpisode(spec, partners=partners, pool=self.pool,
                                    text=self.text and self.numeric is None,
                                    off_menu=self.off_menu, loop=self.loop)
        self._episodes[config.task_id] = episode  # the most recently played, last
        if len(self._episodes) > KEPT_EPISODES:
            evicted = self._episodes.pop(next(iter(self._episodes)))
            self.pool.release(evicted.spec.episode)  # its partners' clients
        return episode

    def _image_shape(self, seat: str, robots: int) -> tuple[int, ...] | None:
        if self._frame is None:
            return None
        return (robots, *self._frame) if seat in (TEAM_SEAT, LEADER_SEAT) else self._frame

    @property
    def state_result(self):
        """The scored result of the ended episode (None before its end)."""
        return self.episode.result if self.episode is not None else None


def check_seed(seed: Any) -> None:
    """A seed is None or a non-negative integer (`EnvError` otherwise)."""
    if seed is None:
        return
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)) \
            or seed < 0:
        raise EnvError(f"seed must be a non-negative integer or None, not {seed!r}")


def check_max_steps(max_steps: Any) -> None:
    """`max_steps` is None (the instance's budget) or a positive integer."""
    if max_steps is None:
        return
    if isinstance(max_steps, (bool, np.bool_)) or not isinstance(max_steps, (int, np.integer)) \
            or max_steps < 1:
        raise EnvError(f"max_steps must be a positive integer (or None: the instance's step "
                       f"budget), not {max_steps!r}")


def check_flag(name: str, value: Any) -> None:
    """A yes/no option is a bool (a string such as "no" would read as yes)."""
    if not isinstance(value, (bool, np.bool_)):
        raise EnvError(f"{name} must be True or False, not {value!r}")


def check_render_mode(render_mode: Any) -> None:
    if render_mode is not None and render_mode not in RENDER_MODES:
        raise EnvError(f"render_mode must be {' or '.join(map(repr, RENDER_MODES))} (or None), "
                       f"not {render_mode!r}")


def reset_options(options: Any) -> Mapping[str, Any]:
    """`reset`'s options checked: None or a dict; a name not in `RESET_OPTIONS` is told in
    an `EnvWarning`, not refused (PettingZoo's API tests pass ``{"options": 1}`` to check
    that `reset` takes options)."""
    if options is None:
        return {}
    if not isinstance(options, Mapping):
        raise EnvError(f"reset options must be a dict such as {{'task_id': …}}, not "
                       f"{options!r}")
    unknown = sorted(set(options) - set(RESET_OPTIONS), key=str)
    if unknown:
        warnings.warn(f"unknown reset option {unknown[0]!r} is not read: the options are "
                      f"{', '.join(RESET_OPTIONS)}", EnvWarning, stacklevel=3)
    return options


def text_view(episode: SeatedEpisode, seat: str) -> str:
    """`seat`'s prompt now (rendered here when the episode skips prompts), else its menu
    lines; what a waiting seat and an ended episode show."""
    if episode.finished:
        result = episode.result
        return (f"the episode has ended ({episode.terminal_reason}): task success "
                f"{result.task_success}, goal progress {result.task_progress}")
    view = episode.view(seat)
    if not view.acting:
        return "(waits this phase)"
    return episode.prompt_text(seat) or "\n".join(view.menu_lines)


def side_by_side(pngs: list[bytes]) -> np.ndarray:
    """PNG frames as one RGB array, left to right."""
    import io

    from PIL import Image

    arrays = [np.asarray(Image.open(io.BytesIO(png)).convert("RGB")) for png in pngs]
    return np.concatenate(arrays, axis=1)


def checked_max_menu(configs: list[TaskConfig], max_menu: int | None) -> int:
    """The largest menu id the action spaces hold: `max_menu`, refused when some instance's
    menu can show a larger id (`largest_action_id`; else a move could land and leave an
    observation the spaces cannot hold); by default the largest any instance can show."""
    largest = {c.task_id: largest_action_id(c) for c in configs}
    if max_menu is None:
        return max(largest.values())
    if isinstance(max_menu, (bool, np.bool_)) or not isinstance(max_menu, (int, np.integer)):
        raise EnvError(f"max_menu must be an integer (or None: the largest menu id the "
                       f"source's instances can show), not {max_menu!r}")
    over = {task: n for task, n in largest.items() if n > max_menu}
    if over:
        task = max(over, key=over.__getitem__)
        raise EnvError(f"max_menu={max_menu} is too small: {len(over)} of the source's "
                       f"instances can show larger menu ids (up to {over[task]}, in {task}); "
                       f"leave max_menu unset or make it >= {over[task]}")
    return max_menu


def _failed(landed: list[dict[str, Any]], seat: str) -> int:
    """How many of the landed steps `seat` answers for failed."""
    if seat == LEADER_SEAT:
        return 0
    return sum(1 for item in landed if not item["skill_result"]["success"]
               and (seat == TEAM_SEAT or item["policy_decision"].get("agent") == seat))


def _invalid(decisions: list[dict[str, Any]], seat: str) -> int:
    """How many of `decisions` are `seat`'s choices off its menu (invalid ids)."""
    agent = None if seat == TEAM_SEAT else seat
    return sum(1 for d in decisions
               if d.get("status") == "invalid_action_id" and d.get("agent") == agent)


def _acts(episode: SeatedEpisode, seat: str) -> bool:
    """Whether `seat` decides in this phase: a learner the planner waits for; a partner
    (which answers as soon as it is asked) while the robots' phase lasts."""
    if seat in episode.partners:
        return not episode.finished and episode.phase != "lead"
    return episode.acting(seat)


def _check_count(config: TaskConfig) -> int:
    """How many goal checks `config`'s instance has: one per goal predicate
    (`goals.GoalSet.evaluate`)."""
    return len(config.goal_predicates)


def _seats_of(config: TaskConfig, planner: str) -> list[str]:
    return [seat_name(s) for s in planner_spec(planner).seats(config.agent_ids)]


def _all_seats(configs: list[TaskConfig], planner: str) -> list[str]:
    seats = dict.fromkeys(s for c in configs for s in _seats_of(c, planner))
    roles = [s for s in seats if s in (TEAM_SEAT, LEADER_SEAT)]
    robots = sorted((s for s in seats if s not in roles), key=_robot_order)
    return [*roles, *robots]


def _robot_order(agent: str) -> tuple[int, str]:
    tail = agent.rpartition("_")[2]
    return (int(tail) if tail.isdigit() else 0, agent)


def _frame_shape(config: TaskConfig) -> tuple[int, ...]:
    """The shape of one robot's frame (rendered once)."""
    from benchmark_adapter.episode import Episode

    world = Episode(config)
    world.reset()
    return tuple(world.frame_pixels(config.agent_ids[0]).shape)


def parallel_env(source: str, *, condition: str, task_id: str | None = None,
                 prompt_suite: str = DEFAULT_SUITE, reward: Mapping[str, float] | None = None,
                 seed: int | None = None, **options: Any) -> CoCoBenchParallelEnv:
    """CoCoBench as a PettingZoo parallel environment: `source` is anything `--task` /
    `--suite` takes, `condition` one condition code (``D1_blind``). Options: ``text``
    (render prompts; default True), ``max_steps``, ``max_menu`` (default: the largest menu id
    the source's instances can show), ``model`` (the name the
    seats' decisions record), ``partners`` (seat → model spec: seats played by a model),
    ``off_menu`` ("error", or "score": an id off the menu scored as a model's invalid id),
    ``observation`` ("text": the prompt and menu lines; "numeric": fixed-size tables of the
    objects, menu entries and goal, `features.py`),
    ``model_settings`` (how the partners' models are called: `ModelSettings` or a mapping of
    its fields; default: the ``COCOBENCH_RUN_*`` variables', as for `cocobench run`)."""
    return CoCoBenchParallelEnv(source, condition=condition, task_id=task_id,
                                prompt_suite=prompt_suite, reward=reward, seed=seed, **options)


def env(source: str, *, condition: str, task_id: str | None = None,
        prompt_suite: str = DEFAULT_SUITE, reward: Mapping[str, float] | None = None,
        seed: int | None = None, **options: Any):
    """The AEC form of `parallel_env` (PettingZoo's own conversion)."""
    return parallel_to_aec(parallel_env(source, condition=condition, task_id=task_id,
                                        prompt_suite=prompt_suite, reward=reward, seed=seed,
                                        **options))


__all__ = ["AGENT_SEAT", "CoCoBenchParallelEnv", "SeatAction", "env", "parallel_env"]
