"""The leaderboard's rows: one per model × scaffold (planner, prompt suite, settings that
matter) × condition of each verified source, with the reports' clustered intervals."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from benchmark_adapter.vocabulary import DIMENSIONS
from cocobench_agents.models import is_builtin
from cocobench_agents.reports.stats import Estimate, cluster_totals, mean_ci, pass_hat_k
from cocobench_agents.runfolder import EpisodeKey, result_key
from cocobench_agents.verify import Verdict

VERIFIED, MISMATCH, UNVERIFIABLE, REFUSED = "verified", "mismatch", "unverifiable", "refused"


@dataclass
class Row:
    """One leaderboard row."""

    source: str  # the bundle's or run folder's name
    pages: str  # its `cocobench view --export` pages, relative to the site
    model: str
    condition: str
    planner: str
    prompt_suite: str
    settings: list[str]  # settings that are not the reference's (empty: the reference's)
    episodes: int
    sr: Estimate
    cs: Estimate
    cs_dims: dict[str, Estimate]
    legal: Estimate
    pass_k: tuple[int, float] | None  # (k, pass^k) where every instance has k epochs
    tokens: float  # per episode
    dollars: float | None  # per episode; None where the model is not priced
    badge: str  # VERIFIED, MISMATCH, UNVERIFIABLE or REFUSED
    why: str = ""  # the first problem, for a row that does not verify
    rank: int | None = None  # within its condition; None: not ranked
    notes: list[str] = field(default_factory=list)

    @property
    def rankable(self) -> bool:
        return self.badge == VERIFIED and not self.settings


def rows_of(source: str, pages: str, lines: Sequence[Mapping[str, Any]],
            verdicts: Mapping[EpisodeKey, Verdict], *, problems: Sequence[str],
            labels: Sequence[str], suites: Mapping[str, str]) -> list[Row]:
    """The rows of one source: its latest `lines`, their `verdicts`, the source's
    `problems` (a refused bundle's rows are all refused), its `labels`, and its prompt
    suites by arm ("" for a run of one suite)."""
    groups: dict[tuple[str, str, str], list[Mapping[str, Any]]] = {}
    for line in lines:
        groups.setdefault((line["model"], line["condition"], line.get("arm") or ""),
                          []).append(line)
    rows = []
    for (model, condition, arm), group in groups.items():
        states = [verdicts.get(result_key(line)) for line in group]
        badge, why = _badge(states, problems)
        rows.append(Row(
            source=source, pages=pages, model=model, condition=condition,
            planner=str(group[0].get("planner") or ""),
            prompt_suite=suites.get(arm) or suites.get("") or str(
                group[0].get("prompt_suite") or ""),
            settings=list(labels), episodes=len(group), **_scores(group),
            badge=badge, why=why))
    return rows


def rank(rows: list[Row]) -> None:
    """Number the rankable rows of each condition by SR (then CS), best first."""
    by_condition: dict[str, list[Row]] = {}
    for row in rows:
        if row.rankable:
            by_condition.setdefault(row.condition, []).append(row)
    for group in by_condition.values():
        group.sort(key=lambda r: (-(r.sr.value or 0.0), -(r.cs.value or 0.0)))
        for number, row in enumerate(group, start=1):
            row.rank = number


def _badge(states: Sequence[Verdict | None], problems: Sequence[str]) -> tuple[str, str]:
    if problems:
        return REFUSED, problems[0]
    for status in (MISMATCH, UNVERIFIABLE):
        found = [v for v in states if v is not None and v.status == status]
        if found:
            return status, f"{len(found)} episode(s) {status}: {found[0].describe()}"
    if any(v is None for v in states):
        return UNVERIFIABLE, "an episode was not replayed"
    return VERIFIED, ""


def _scores(group: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    tasks = [line["task_id"] for line in group]
    success = _column(group, "task_success")
    cs = _column(group, "construct_score")
    dims = np.array([line.get("dim") for line in group], dtype=object)
    usage = [line.get("usage") or {} for line in group]
    costs = [float(u.get("cost_usd") or 0.0) for u in usage]
    # Priced: a cost was recorded, or nothing could cost (a built-in model, no model call);
    # a model called at no recorded cost (a local server) has tokens but no price.
    calls = sum(float(u.get("model_calls") or 0) for u in usage)
    priced = is_builtin(group[0]["model"]) or calls == 0 or any(cost > 0 for cost in costs)
    return {
        "sr": mean_ci(success, clusters=tasks),
        "cs": mean_ci(cs, clusters=tasks),
        "cs_dims": {d: mean_ci(cs[dims == d], clusters=np.array(tasks)[dims == d])
                    for d in DIMENSIONS},
        "legal": mean_ci(_column(group, "legal_plan"), clusters=tasks),
        "pass_k": _pass_k(success, tasks),
        "tokens": float(np.mean([float(u.get("prompt_tokens") or 0)
                                 + float(u.get("completion_tokens") or 0) for u in usage])),
        "dollars": float(np.mean(costs)) if priced else None,
    }


def _column(group: Sequence[Mapping[str, Any]], name: str) -> np.ndarray:
    return np.array([np.nan if line.get(name) is None else float(line[name])
                     for line in group], dtype=np.float64)


def _pass_k(success: np.ndarray, tasks: Sequence[str]) -> tuple[int, float] | None:
    """pass^k with k the epochs every instance has, when that is at least 2."""
    successes, trials = cluster_totals(success, tasks)
    if trials.size == 0 or trials.min() < 2:
        return None
    k = int(trials.min())
    return k, float(np.nanmean(pass_hat_k(successes, trials, k)))
