"""`EpisodeTools`: the adapter between planner graphs and a live `Episode`.

Graph nodes never touch the simulator directly: they ask this object for the observation a
prompt needs, hand back the calls to land, and record every decision. At the end it emits the
scored trajectory.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from benchmark_adapter.episode import Episode, Observation
from benchmark_adapter.menu import MenuEntry, menu_lines
from benchmark_adapter.metrics import EpisodeResult, score_trajectory
from benchmark_adapter.sim.embedded.render import merge_agent_frames
from benchmark_adapter.skills import SkillResult
from benchmark_adapter.trajectory import PROMPTS_FIELD, write_json_atomic
from benchmark_adapter.vocabulary import IMAGE, OBSERVATION_MODES
from cocobench_agents.models.protocol import MenuOption
from cocobench_agents.prompts import (
    PromptInputs,
    PromptSuite,
    coordination_hint,
    render_centralized,
    render_distributed,
    render_leader,
    render_own,
)
from cocobench_agents.tools.decisions import prompt_hash

#: How many agent menu views an episode keeps (one per agent and menu seen).
MENU_VIEWS = 1024
COUNTED_PARSE_ERRORS = ("parse_error", "invalid_action_id")


class EpisodeTools:
    """One episode as a planner sees it."""

    def __init__(self, episode: Episode, suite: PromptSuite, *, obs_mode: str = IMAGE,
                 stable_ids: bool = False) -> None:
        if obs_mode not in OBSERVATION_MODES:
            modes = " or ".join(repr(mode) for mode in OBSERVATION_MODES)
            raise ValueError(f"obs_mode must be {modes}, not {obs_mode!r}")
        self.episode, self.suite, self.obs_mode = episode, suite, obs_mode
        self.stable_ids = stable_ids
        self.config = episode.config
        self.hint = coordination_hint(self.config, suite)
        self.decisions: list[dict[str, Any]] = []
        self.prompts: dict[str, str] = {}  # every prompt rendered, by `prompt_hash`
        self.counters = {"planner_steps": 0, "parse_errors": 0, "backend_errors": 0}
        self._stable: dict[str, int] = {}
        # Each agent's view by the menu list it was built from (the episode hands the same
        # list out again when the same menu comes back); `view.source is` guards the id.
        self._views: dict[tuple[str | None, int], _MenuView] = {}
        self.snapshot: Observation | None = None
        # Called with each landed step's trajectory item (e.g. to stream it to a client).
        self.on_step: Callable[[dict[str, Any]], None] | None = None

    # -- observation -------------------------------------------------------------------

    @property
    def agents(self) -> list[str]:
        return self.config.agent_ids

    @property
    def step_index(self) -> int:
        return self.episode.step_index

    def start(self) -> Observation:
        """Reset the episode and take the first snapshot."""
        self.episode.reset()
        return self.refresh()

    def refresh(self) -> Observation:
        """Take a new snapshot; every decision of a round reads the same one."""
        self.snapshot = self.episode.observe()
        return self.snapshot

    def menu_options(self, agent: str | None = None) -> tuple[MenuOption, ...]:
        """`agent`'s menu as model clients see it."""
        return self._menu_view(agent).options

    def _menu_view(self, agent: str | None) -> _MenuView:
        # The episode hands out the same menu list until the menu changes, so each agent's
        # view is built once per menu rather than once per decision.
        source = self.snapshot.action_menu
        view = self._views.get((agent, id(source)))
        if view is None or view.source is not source:
            entries = source if agent is None else [e for e in source if e.agent == agent]
            if self.stable_ids:  # a call keeps the id it was first shown with
                entries = [dataclasses.replace(
                    e, action_id=self._stable.setdefault(e.call, len(self._stable) + 1))
                    for e in entries]
            if len(self._views) >= MENU_VIEWS:
                self._views.clear()
            view = self._views[agent, id(source)] = _MenuView(source, entries, agent is None)
        return view

    def menu_lines(self, agent: str | None = None) -> list[str]:
        """`agent`'s menu as its prompt lists it."""
        return list(self._menu_view(agent).lines)

    def prompt(self, agent: str | None, history: Sequence[str],
               messages: Sequence[Mapping[str, str]] = (), broadcast: bool = False,
               with_images: bool = True) -> tuple[str, tuple[bytes, ...], list[MenuEntry]]:
        """Prompt text, images and menu for one decision (`agent=None`: centralized).

        Images are rendered only in image mode and only for a model that reads them.
        """
        view = self._menu_view(agent)
        menu = view.entries
        inputs = self._inputs(view.lines, history, messages)
        if agent is None:
            text = render_centralized(self.suite, inputs)
        else:
            text = render_distributed(self.suite, inputs, agent, broadcast)
        return self.keep(text), self.images(agent) if with_images else (), menu

    def leader_prompt(self, history: Sequence[str], with_images: bool = True
                      ) -> tuple[str, tuple[bytes, ...]]:
        """The leader–worker strategy's leader prompt and images (the team view)."""
        inputs = self._inputs(self._menu_view(None).lines, history, ())
        text = self.keep(render_leader(self.suite, inputs))
        return text, self.images(None) if with_images else ()

    def ask_prompt(self, agent: str | None, template: str, fields: Mapping[str, object],
                   options: Sequence[MenuOption], history: Sequence[str] = (),
                   with_images: bool = True, placeholders: bool = False
                   ) -> tuple[str, tuple[bytes, ...]]:
        """A planner's own `template` rendered for `agent` (None: the team) with the
        strategy's `fields`, its `{menu}` listing `options` (``id: call``), and its images;
        kept like every prompt (`ask`). With `placeholders`, a field not given shows as
        ``{name}`` (a preview, a dry run); with `options` empty, so does ``{menu}``."""
        lines = [f"{o.action_id}: {o.call}" for o in options]
        inputs = self._inputs(lines, history, ())
        if placeholders and not options:
            fields = {"menu": "{menu}", **fields}
        text = self.keep(render_own(self.suite, template, inputs, agent, fields,
                                    placeholders=placeholders))
        return text, self.images(agent) if with_images else ()

    def keep(self, prompt: str) -> str:
        """`prompt`, kept with the trajectory under its `prompt_hash`."""
        # Decisions record a prompt by its hash; the text goes with the trajectory (the run
        # folder stores it compressed), so what a model saw can be read back.
        self.prompts.setdefault(prompt_hash(prompt), prompt)
        return prompt

    def _inputs(self, menu_lines: Sequence[str], history: Sequence[str],
                messages: Sequence[Mapping[str, str]]) -> PromptInputs:
        snap = self.snapshot
        return PromptInputs(
            agents=self.agents, goal_text=snap.goal_text, progress_text=snap.progress_text,
            hint=self.hint, menu_lines=menu_lines,
            history=history, inventories=snap.inventories, obs_mode=self.obs_mode,
            messages=messages,
        )

    def images(self, agent: str | None) -> tuple[bytes, ...]:
        """The frames a decision of `agent` shows (None: the team's merged view); none in
        blind mode."""
        if self.obs_mode != IMAGE:
            return ()
        if agent is not None:
            return (self.episode.frame(agent),)
        return (merge_agent_frames([(a, self.episode.frame(a)) for a in self.agents]),)

    # -- acting and recording ------------------------------------------------------------

    def land(self, call: str, *, decision: dict[str, Any] | None = None,
             round_index: int | None = None, message: str | None = None) -> SkillResult:
        """Execute one chosen call as a recorded step."""
        result = self.episode.step(call, round_index=round_index, message=message,
                                   decision=decision)
        if self.on_step is not None:
            self.on_step(self.episode.items[-1])
        return result

    def record(self, decision: dict[str, Any], model_call: bool = True) -> dict[str, Any]:
        """Count a decision (cumulative counters, as the reference records them) and keep it."""
        if model_call:
            self.counters["planner_steps"] += 1
        if decision["status"] in COUNTED_PARSE_ERRORS:
            self.counters["parse_errors"] += 1
        if decision["status"] == "backend_error":
            self.counters["backend_errors"] += 1
        decision.update(self.counters)
        self.decisions.append(decision)
        return decision

    def stop(self, decision: dict[str, Any]) -> None:
        """Record the decision that ended the episode."""
        self.episode.stop(decision)

    def finish(self, path: str | Path | None = None, **identifiers: Any
               ) -> tuple[dict[str, Any], EpisodeResult]:
        """The trajectory (with every decision, and under `PROMPTS_FIELD` the text of every
        prompt a decision names by its `prompt_hash`) and its scored result."""
        document = self.episode.finish()
        document["planner_decisions"] = self.decisions
        used = {d.get("prompt_hash") for d in self.decisions}
        if used.intersection(self.prompts):
            document[PROMPTS_FIELD] = {h: p for h, p in self.prompts.items() if h in used}
        if path is not None:
            write_json_atomic(path, document)
        return document, score_trajectory(document, **identifiers)


class _MenuView:
    """One agent's menu, its lines and the options clients see, built from one menu list."""

    def __init__(self, source: list[MenuEntry], entries: list[MenuEntry], centralized: bool):
        self.source, self.entries = source, entries
        self.lines = menu_lines(entries, centralized=centralized)
        self.options = tuple(MenuOption(e.action_id, e.skill, e.call) for e in entries)
