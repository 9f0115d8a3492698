"""The viewer's pages, rendered from Jinja templates. Every page path is relative to the
viewer's root and every link in a page is relative to the page, so the same HTML works
served live and exported as static files."""

from __future__ import annotations

import json
import urllib.parse
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any

import jinja2

from benchmark_adapter.metrics.constructs import construct_score
from benchmark_adapter.vocabulary import (
    LOAD_BALANCING,
    MUTUAL_EXCLUSION,
    PRECEDENCE,
    PRODUCER_CONSUMER,
)
from cocobench_agents.conditions import split_condition
from cocobench_agents.graphs.plugins import installed_planners
from cocobench_agents.graphs.registry import PLANNERS
from cocobench_agents.runfolder.errors import gist
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
from cocobench_agents.viewer.signals import STEP_CATEGORIES, Gantt, construct_signal, gantt
from cocobench_agents.viewer.source import Catalog, Episode, RunSource
from cocobench_agents.viewer.timeline import NO_PROMPT, NO_REPLY, Timeline, build_timeline

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
    #: Why an episode's page shows only its result line, by page (the trajectory cannot be
    #: drawn): `--export` says how many.
    unshown: dict[str, str] = field(default_factory=dict)

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
        """An episode's page; when its trajectory is missing, unreadable or cannot be drawn
        (a malformed field of a shared run folder), its result line with a warning."""
        run = self.catalog.runs[episode.run]
        traj = run.trajectory(episode)
        problem = None
        if traj is not None and isinstance(traj.get("trajectory"), list):
            try:
                return self._episode_views(episode, run, traj)
            except Exception as exc:  # noqa: BLE001 - any field of a run folder may be odd
                problem = f"{run.trajectory_name(episode)}: {describe(exc)}"
                self.unshown[episode.path] = f"{run.path}/{problem}"
        return self._render("episode.html", episode.path, episode=episode, run=run, traj=None,
                            problem=problem, **_outcome(episode.record, None))

    def _episode_views(self, episode: Episode, run: RunSource, traj: dict[str, Any]) -> str:
        timeline = build_timeline(traj, run.prompts(episode))
        for entry in timeline.entries:
            entry.image = frame_href(run, entry.image)
        config = _mapping(traj.get("task_config"))
        agents = team_of(config)
        return self._render(
            "episode.html", episode.path, episode=episode, run=run, traj=traj, config=config,
            agents=agents, timeline=timeline,
            gantt=gantt([a["id"] for a in agents], timeline.steps, timeline.categories),
            signal=construct_signal(traj, timeline.steps),
            goal=_goal(traj), compare_href=compare_path(episode.key.task_id),
            board=bool(timeline.messages) or broadcasts(episode.record, run.record) is True,
            **_outcome(episode.record, traj))

    def compare_page(self, path: str) -> str | None:
        """The compare page at `path` (`compare/TASK.html`), None when no instance has it."""
        task_ids = {compare_path(e.key.task_id): e.key.task_id for e in self.catalog.episodes()}
        return self.compare(task_ids[path]) if path in task_ids else None

    def compare(self, task_id: str) -> str | None:
        """Every episode of one instance side by side, aligned by landed step (None if the
        runs hold no episode of it)."""
        episodes = [e for e in self.catalog.episodes() if e.key.task_id == task_id]
        if not episodes:
            return None
        columns = []
        for e in episodes:
            run = self.catalog.runs[e.run]
            timeline, chart = self._compared(e, run)
            columns.append({"episode": e, "run": run, "timeline": timeline, "gantt": chart,
                            "cells": dict(zip(CELL_KEYS, self._row(e)["v"]))})
        depth = max((len(c["timeline"].steps) for c in columns if c["timeline"]), default=0)
        return self._render("compare.html", compare_path(task_id), task_id=task_id,
                            columns=columns, depth=depth)

    @staticmethod
    def _compared(episode: Episode, run: RunSource) -> tuple[Timeline | None, Gantt | None]:
        """An episode's timeline and Gantt for the compare page; none when its trajectory is
        missing or cannot be drawn (the column then says so)."""
        traj = run.trajectory(episode)
        if traj is None or not isinstance(traj.get("trajectory"), list):
            return None, None
        try:
            timeline = build_timeline(traj, run.prompts(episode))
            agents = [a["id"] for a in team_of(_mapping(traj.get("task_config")))]
            return timeline, gantt(agents, timeline.steps, timeline.categories)
        except Exception:  # noqa: BLE001 - any field of a run folder may be odd
            return None, None

    def _row(self, episode: Episode) -> dict[str, Any]:
        key = (episode.run, episode.seq)
        if key not in self._rows:
            self._rows[key] = episode_row(episode, self.catalog.runs[episode.run].name)
        return self._rows[key]

    def _render(self, template: str, page: str, **context: Any) -> str:
        html = self.env.get_template(template).render(
            root=root_of(page), live=self.live, junk=self.catalog.junk,
            team_label=team_label, seat_models=seat_models,
            problems=[p for run in self.catalog.runs for p in run.problems], **context)
        # A lone surrogate (JSON's "\ud800", read from a run folder) cannot be sent or
        # written as UTF-8: it is shown as "?".
        return html.encode("utf-8", "replace").decode("utf-8")


def broadcasts(record: Mapping[str, Any], run_record: Mapping[str, Any]) -> bool | None:
    """Whether the episode's planner broadcasts (its spec's `broadcast`), so that its page
    shows the message board even when nobody posted; None when that is unknown (the board is
    then shown only when messages were posted).

    Run data is data: this never loads, imports or runs anything the run folder names (its
    condition may be `FILE.py:NAME_blind`). It asks the planners shipped with the package, what
    `run.json` recorded of the run's own planners (`planners.NAME.broadcast`, recorded since
    the field exists), and the planners installed in this environment."""
    planner = record.get("planner")
    planner = planner if isinstance(planner, str) else ""
    code = split_condition(str(record.get("condition") or ""))[0]
    recorded = _mapping(_mapping(run_record.get("planners")).get(planner)).get("broadcast")
    if isinstance(recorded, bool) and planner not in PLANNERS:
        return recorded
    return _known_broadcast(planner, code)


@lru_cache(maxsize=1024)
def _known_broadcast(planner: str, code: str) -> bool | None:
    """`broadcast` of the built-in or installed planner named `planner` or whose condition
    code is `code`; None when no such planner is here."""
    for spec in PLANNERS.values():
        if planner == spec.name or code in (spec.name, spec.code):
            return spec.broadcast
    for loaded in installed_planners():  # the packages installed here, never a run's files
        if loaded.spec is not None and (planner == loaded.name or code == loaded.spec.code):
            return loaded.spec.broadcast
    return None


def frame_href(run: RunSource, image: str | None) -> str | None:
    """Where a page finds a trajectory item's frame, relative to the viewer's root: a
    `data:image/` URI as it is, a file inside the run folder by its path there (below
    `files/RUN/`, the path `export` copies it to); None for anything else."""
    if image is None:
        return None
    if image.startswith("data:image/"):
        return image
    relative = run.relative(image)
    return None if relative is None else f"files/{run.index}/{urllib.parse.quote(relative)}"


def team_of(config: Mapping[str, Any]) -> list[dict[str, Any]]:
    """The agents of a task config, each with a text `id` (an agent recorded without one,
    or as something other than an object, is left out)."""
    agents = config.get("agents")
    return [{**a, "id": str(a["id"])} for a in agents if isinstance(a, Mapping)
            and isinstance(a.get("id"), (str, int))] if isinstance(agents, list) else []


def describe(exc: BaseException) -> str:
    """An exception in one line, short: its type and the first line of its message."""
    return f"{type(exc).__name__}: {gist(exc)}"


def _mapping(value: Any) -> Mapping[str, Any]:
    return value if isinstance(value, Mapping) else {}


def _outcome(record: Mapping[str, Any], traj: Mapping[str, Any] | None) -> dict[str, Any]:
    """The construct score with its evidence: the result line's, else recomputed from the
    trajectory by the benchmark's scorer (none when it cannot be)."""
    dim = record.get("dim")
    block = _mapping(record.get("cross_construct")).get(dim) if isinstance(dim, str) else None
    if not isinstance(block, Mapping) and traj is not None:
        try:
            score = construct_score(traj)
            block = {"dim": score.dim, "score": score.score, "status": score.status,
                     "sample": score.sample, "evidence": score.evidence}
        except Exception:  # noqa: BLE001 - TrajectoryError, or a field of an odd type
            block = None
    card = _construct_card(block) if isinstance(block, Mapping) else None
    return {"construct": card, "formula": FORMULAS.get(str(dim), "")}


def _construct_card(block: Mapping[str, Any]) -> dict[str, Any]:
    """What the construct card shows of a score block, each field as text; evidence that
    is not an object is said to be malformed rather than drawn."""
    score = block.get("score")
    evidence = block.get("evidence")
    if isinstance(evidence, Mapping):
        shown = [(str(k), _evidence_text(v)) for k, v in evidence.items()]
    elif evidence is None:
        shown = []
    else:
        shown = [("evidence", f"malformed (a {type(evidence).__name__}, not an object)")]
    return {"score": score if isinstance(score, (int, float)) and not isinstance(score, bool)
            else None, "status": str(block.get("status") or ""),
            "sample": _evidence_text(block.get("sample")), "evidence": shown}


def _evidence_text(value: Any) -> str:
    """One evidence value as the card shows it: a list of plain values joined, anything
    else as (at most 200 characters of) JSON."""
    if isinstance(value, str):
        return value
    if isinstance(value, list) and all(isinstance(v, (str, int, float)) for v in value):
        return ", ".join(map(str, value))
    try:
        text = json.dumps(value, ensure_ascii=False, default=str)
    except (ValueError, RecursionError):  # nested too deep
        return "…"
    return text if len(text) <= 200 else text[:199] + "…"


def _goal(traj: Mapping[str, Any]) -> dict[str, Any]:
    config = _mapping(traj.get("task_config"))
    provenance = _mapping(config.get("provenance"))
    final = _mapping(traj.get("final_eval"))
    checks = final.get("checks")
    return {"instruction": str(provenance.get("instruction") or config.get("task_name") or ""),
            "checks": [c for c in checks if isinstance(c, Mapping)]
            if isinstance(checks, list) else [],
            "success": bool(final.get("success")) if final else None}


def _natural(text: str) -> tuple[int, float | str]:
    try:
        return 0, float(text)
    except ValueError:
        return 1, text
