"""The viewer's pages, rendered from Jinja templates. Every page path is relative to the
viewer's root and every link in a page is relative to the page, so the same HTML works
served live and exported as static files."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cache
from typing import Any

import jinja2

from benchmark_adapter.metrics.constructs import construct_score
from benchmark_adapter.metrics.errors import TrajectoryError
from benchmark_adapter.vocabulary import (
    LOAD_BALANCING,
    MUTUAL_EXCLUSION,
    PRECEDENCE,
    PRODUCER_CONSUMER,
)
from cocobench_agents.conditions import split_condition
from cocobench_agents.graphs import PlannerError, find_planner, planner_spec
from cocobench_agents.runfolder.result_line import CS_NOTE
from cocobench_agents.runfolder.summary import HEADERS, LEGEND, summary_table
from cocobench_agents.viewer.rows import (
    COLUMNS,
    FILTERS,
    compare_path,
    episode_row,
    seat_models,
    team_label,
)
from cocobench_agents.viewer.signals import STEP_CATEGORIES, construct_signal, gantt
from cocobench_agents.viewer.source import Catalog, Episode
from cocobench_agents.viewer.timeline import NO_PROMPT, NO_REPLY, build_timeline

CELL_KEYS = [key for key, _, _ in COLUMNS]
#: How each dimension's construct score is computed from its evidence (shown beside it).
FORMULAS = {
    LOAD_BALANCING:
        "C = M* / makespan (clipped to 1): the busiest agent's steps against the reference",
    PRECEDENCE: "C = (1 − v / n) × legality factor, v = violations, n = correct + violations",
    MUTUAL_EXCLUSION: "C = (1 − c / a) × efficiency, c = collisions, a = accesses",
    PRODUCER_CONSUMER: "C = 1 − (o + w) / h, h = handoffs, o = overflows, w = starved waits",
}


def environment() -> jinja2.Environment:
    env = jinja2.Environment(
        loader=jinja2.PackageLoader("cocobench_agents.viewer", "templates"),
        autoescape=jinja2.select_autoescape(["html"]), trim_blocks=True, lstrip_blocks=True)
    env.globals.update(columns=COLUMNS, filters=FILTERS, categories=STEP_CATEGORIES,
                       NO_PROMPT=NO_PROMPT, NO_REPLY=NO_REPLY, legend=LEGEND, cs_note=CS_NOTE)
    return env


def root_of(page: str) -> str:
    """The relative path from a page back to the viewer's root (`episode/0/a/b/c.html` ->
    `../../../../`)."""
    return "../" * page.count("/")


@dataclass
class Pages:
    """Renders the pages of a catalog of runs; `live` pages poll for new episodes."""

    catalog: Catalog
    live: bool
    env: jinja2.Environment
    # Rows and the summary are made once per result line: a live page of thousands of
    # episodes re-renders only what changed.
    _rows: dict[tuple[int, int], dict[str, Any]] = field(default_factory=dict)
    _summary: tuple[int, tuple[tuple[str, ...], list[list[Any]]]] = (-1, (HEADERS, []))

    @classmethod
    def create(cls, catalog: Catalog, *, live: bool) -> Pages:
        return cls(catalog, live, environment())

    def runs(self) -> str:
        episodes = self.catalog.episodes()
        rows = [self._row(e) for e in episodes]
        index = {key: i for i, (key, _, _) in enumerate(COLUMNS)}
        values = {key: sorted({r["v"][index[key]] for r in rows}, key=_natural)
                  for key in FILTERS}
        if self._summary[0] != self.catalog.seq:
            # A human–AI team is its own row, named by its seats' models.
            self._summary = (self.catalog.seq, summary_table(
                {**e.record, "model": team_label(e.record)} for e in episodes))
        headers, summary = self._summary[1]
        return self._render("runs.html", "index.html", runs=self.catalog.runs, rows=rows,
                            values=values, headers=headers, summary=summary,
                            seq=self.catalog.seq)

    def new_rows(self, since: int) -> dict[str, Any]:
        """The rows of episodes that arrived after sequence number `since` (for the live
        runs page), with the counts the page shows."""
        fresh = [e for e in self.catalog.episodes() if e.seq >= since]
        return {"seq": self.catalog.seq, "rows": [self._row(e) for e in fresh],
                "episodes": sum(len(r.episodes) for r in self.catalog.runs),
                "junk": self.catalog.junk}

    def episode(self, episode: Episode) -> str:
        run = self.catalog.runs[episode.run]
        traj = run.trajectory(episode)
        page = episode.path
        if traj is None or not isinstance(traj.get("trajectory"), list):
            return self._render("episode.html", page, episode=episode, run=run, traj=None,
                                **_outcome(episode.record, None))
        timeline = build_timeline(traj, run.prompts(episode))
        config = traj.get("task_config") or {}
        agents = [a for a in config.get("agents") or [] if isinstance(a, Mapping)]
        return self._render(
            "episode.html", page, episode=episode, run=run, traj=traj, config=config,
            agents=agents, timeline=timeline,
            gantt=gantt([str(a.get("id")) for a in agents], timeline.steps, timeline.categories),
            signal=construct_signal(traj, timeline.steps),
            goal=_goal(traj), compare_href=compare_path(episode.key.task_id),
            board=bool(timeline.messages) or broadcasts(episode.key.condition),
            **_outcome(episode.record, traj))

    def compare(self, task_id: str) -> str | None:
        """Every episode of one instance side by side, aligned by landed step (None if the
        runs hold no episode of it)."""
        episodes = [e for e in self.catalog.episodes() if e.key.task_id == task_id]
        if not episodes:
            return None
        columns = []
        for e in episodes:
            run = self.catalog.runs[e.run]
            traj = run.trajectory(e)
            timeline = build_timeline(traj, run.prompts(e)) if traj and isinstance(
                traj.get("trajectory"), list) else None
            agents = [str(a.get("id")) for a in ((traj or {}).get("task_config") or {}).get(
                "agents") or [] if isinstance(a, Mapping)]
            chart = gantt(agents, timeline.steps, timeline.categories) if timeline else None
            columns.append({"episode": e, "run": run, "timeline": timeline, "gantt": chart,
                            "cells": dict(zip(CELL_KEYS, self._row(e)["v"]))})
        depth = max((len(c["timeline"].steps) for c in columns if c["timeline"]), default=0)
        return self._render("compare.html", compare_path(task_id), task_id=task_id,
                            columns=columns, depth=depth)

    def _row(self, episode: Episode) -> dict[str, Any]:
        key = (episode.run, episode.seq)
        if key not in self._rows:
            self._rows[key] = episode_row(episode, self.catalog.runs[episode.run].name)
        return self._rows[key]

    def _render(self, template: str, page: str, **context: Any) -> str:
        return self.env.get_template(template).render(
            root=root_of(page), live=self.live, junk=self.catalog.junk,
            team_label=team_label, seat_models=seat_models,
            problems=[p for run in self.catalog.runs for p in run.problems], **context)


@cache
def broadcasts(condition: str) -> bool:
    """Whether the planner of `condition` broadcasts (its spec's `broadcast`), so that its
    episodes show the message board even when nobody posted. A planner this process cannot
    find (a file of someone else's run, a package not installed here) shows the board only
    when messages were posted."""
    try:
        name = find_planner(split_condition(condition)[0])
        return name is not None and planner_spec(name).broadcast
    except PlannerError:
        return False


def _outcome(record: Mapping[str, Any], traj: Mapping[str, Any] | None) -> dict[str, Any]:
    """The construct score with its evidence: the result line's, else recomputed from the
    trajectory by the benchmark's scorer."""
    dim = record.get("dim")
    block = (record.get("cross_construct") or {}).get(dim) if dim else None
    if not isinstance(block, Mapping) and traj is not None:
        try:
            score = construct_score(traj)
            block = {"dim": score.dim, "score": score.score, "status": score.status,
                     "sample": score.sample, "evidence": score.evidence}
        except TrajectoryError:
            block = None
    return {"construct": block, "formula": FORMULAS.get(str(dim), "")}


def _goal(traj: Mapping[str, Any]) -> dict[str, Any]:
    config = traj.get("task_config") or {}
    provenance = config.get("provenance") or {}
    final = traj.get("final_eval") or {}
    checks = final.get("checks") if isinstance(final, Mapping) else None
    return {"instruction": provenance.get("instruction") or config.get("task_name") or "",
            "checks": [c for c in checks or [] if isinstance(c, Mapping)],
            "success": bool(final.get("success")) if isinstance(final, Mapping) else None}


def _natural(text: str) -> tuple[int, float | str]:
    try:
        return 0, float(text)
    except ValueError:
        return 1, text
