"""An episode's first decision round, as its model clients would send it, without calling a
model: the seats its planner's spec declares (`PlannerSpec.seats`), each seat's first prompt
rendered on the embedded simulator through the planners' own code (`EpisodeTools`, as
`cocobench prompts show` does) and turned into the chat messages the clients send
(`build_messages`); and each of the planner's own templates (`PlannerSpec.templates`, which
`ask` renders) once per seat, its strategy's fields shown as `{name}`. The dry run counts
their tokens (`estimate`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from benchmark_adapter.episode import Episode
from benchmark_adapter.vocabulary import IMAGE
from cocobench_agents.episode_runner import EpisodeSpec
from cocobench_agents.graphs import PlannerSpec, planner_spec
from cocobench_agents.graphs.registry import LEADER_SEAT
from cocobench_agents.models import build_messages, is_builtin
from cocobench_agents.models.protocol import ModelRequest
from cocobench_agents.prompts import PromptSuite, load_prompt_suite
from cocobench_agents.tools import EpisodeTools


@dataclass(frozen=True)
class FirstRequest:
    """One model call of an episode's first decision round, as its client would send it."""

    role: str  # the seat: "team", "leader" or "agent" (`graphs.Seat`)
    agent: str | None  # the deciding agent (None for the team's planner and the leader)
    model: str
    messages: list[dict[str, Any]]  # [] when the seat has nothing to decide (empty menu)
    template: str | None = None  # a planner's own template (an `ask`); None: the decision


def first_round_requests(spec: EpisodeSpec) -> list[FirstRequest]:
    """The requests of `spec`'s first decision round, in the order the planner makes them,
    rendered on the embedded simulator without calling a model (none for a planner that
    calls no model).

    The leader–worker's agents are shown without the leader's instruction, which is not known
    before the leader answers; so are a sequential strategy's later seats without what the
    earlier ones posted this round (claim-board's claims)."""
    return FirstRounds().requests(spec, planner_spec(spec.planner))


@dataclass(frozen=True)
class _SeatPrompt:
    """One seat's first prompt as rendered: "" when the seat has no menu (no call)."""

    role: str
    agent: str | None
    text: str
    frames: tuple[bytes, ...]
    template: str | None = None


class FirstRounds:
    """Renders first rounds, once per distinct (instance, planner shape, observation mode,
    suite, id mode, images): a plan repeats them across models, epochs and agent models."""

    def __init__(self) -> None:
        self._suites: dict[tuple, PromptSuite] = {}
        self._worlds: dict[int, Episode] = {}
        self._rendered: dict[tuple, list[_SeatPrompt]] = {}

    def requests(self, spec: EpisodeSpec, planner: PlannerSpec) -> list[FirstRequest]:
        """The first round of episode `spec`, whose planner is `planner`."""
        seats = planner.seats(spec.config.agent_ids)
        models = [spec.model_for(seat.agent) for seat in seats]
        images = spec.obs_mode == IMAGE and any(_reads_images(m) for m in models)
        # Keyed by the config object: a plan's episodes share one per instance, and all of
        # them are alive while the estimate runs.
        key = (id(spec.config), tuple(seats), planner.broadcast, spec.obs_mode,
               spec.prompt_suite, spec.stable_ids, images, tuple(planner.templates.items()))
        rendered = self._rendered.get(key)
        if rendered is None:
            rendered = self._rendered[key] = self._render(spec, planner, images)
        out = []
        for seat in rendered:
            model = spec.model_for(seat.agent)
            frames = seat.frames if _reads_images(model) else ()
            messages = build_messages(ModelRequest(prompt=seat.text, images=frames))
            out.append(FirstRequest(seat.role, seat.agent, model,
                                    messages if seat.text else [], seat.template))
        return out

    def _render(self, spec: EpisodeSpec, planner: PlannerSpec, images: bool
                ) -> list[_SeatPrompt]:
        """Every seat's first prompt, in the order the planner's nodes render them (the order
        `--stable-ids` numbers calls in)."""
        suite_key = (spec.prompt_suite, tuple(planner.templates.items()))
        suite = self._suites.get(suite_key)
        if suite is None:
            suite = self._suites[suite_key] = load_prompt_suite(spec.prompt_suite,
                                                                planner.templates)
        # One world per instance, reset once: every planner's first snapshot is the same
        # one, and the episode renders each agent's frame of a step once (most of the time
        # of an estimate goes into encoding frames).
        world = self._worlds.get(id(spec.config))
        if world is None:
            world = self._worlds[id(spec.config)] = Episode(spec.config)
            world.reset()
        tools = EpisodeTools(world, suite, obs_mode=spec.obs_mode, stable_ids=spec.stable_ids)
        tools.refresh()  # `start` without the reset: fresh menu views and stable ids
        out = []
        for seat in planner.seats(spec.config.agent_ids):
            if seat.role == LEADER_SEAT:  # the leader is always asked (leader_worker.lead)
                text, frames = tools.leader_prompt([], with_images=images)
            else:
                text, frames, menu = tools.prompt(seat.agent, [], (), planner.broadcast,
                                                  with_images=images)
                if not menu:  # `decide` makes no call on an empty menu
                    text, frames = "", ()
            out.append(_SeatPrompt(seat.role, seat.agent, text, frames))
        for seat in planner.seats(spec.config.agent_ids):
            if seat.role == LEADER_SEAT:
                continue
            for name in planner.templates:  # as `ask` renders it, the strategy's fields unknown
                text, frames = tools.ask_prompt(seat.agent, name, {}, (), placeholders=True,
                                                with_images=images)
                out.append(_SeatPrompt(seat.role, seat.agent, text, frames, name))
        return out


def _reads_images(model: str) -> bool:
    """Built-in clients read no frames (`accepts_images = False`), so none are rendered for
    them; remote models get them under image conditions."""
    return not is_builtin(model)
