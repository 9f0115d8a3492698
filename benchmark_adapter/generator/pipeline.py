"""From strata to kept instances: candidate streams, the gates, and the rejection counts.

Each stratum (task type × team size × room) has a fixed, endless-enough stream of candidates:
spawn seeds 0, 1, … over the room's scenes in a stratum-specific order. Candidates are judged
in batches (in worker processes with `jobs > 1`) and the first `count` that pass every gate
are kept. Only candidates up to the last kept one count as considered, so the kept instances
and the rejection counts do not depend on `jobs` or on batch sizes.
"""

from __future__ import annotations

import functools
import os
from collections.abc import Iterator
from concurrent.futures import Executor, ProcessPoolExecutor
from contextlib import nullcontext
from dataclasses import dataclass, field
from itertools import islice
from typing import Any

from benchmark_adapter.generator.builder import assemble
from benchmark_adapter.generator.composition import Stratum, full_strata
from benchmark_adapter.generator.gates import GATES, Verdict, judge
from benchmark_adapter.generator.ids import task_id
from benchmark_adapter.generator.scenes import (
    SCENES_PER_ROOM,
    Scene,
    embedded_scene,
    seeded_rng,
)
from benchmark_adapter.generator.templates import TASK_TYPES, TaskType, Ungroundable
from benchmark_adapter.vocabulary import DEFAULT_BACKEND

MAX_SEEDS = 12  # spawn seeds a stratum may draw on before the generator gives up


class GenerationError(RuntimeError):
    """A stratum ran out of candidates before enough of them passed the gates."""


@dataclass(frozen=True)
class Candidate:
    """A grounded candidate config, or the reason its template could not be grounded."""

    task_id: str
    config: dict[str, Any] | None
    problem: str = ""


@dataclass
class StratumResult:
    """The kept configs of one stratum and the verdict on every candidate considered."""

    stratum: Stratum
    kept: list[dict[str, Any]] = field(default_factory=list)
    verdicts: list[Verdict] = field(default_factory=list)

    @property
    def full(self) -> bool:
        return len(self.kept) >= self.stratum.count


def make_candidate(task_type: TaskType, scene: Scene, agents: int, seed: int) -> Candidate:
    """Ground a task type in a scene; a scene lacking what it needs gives a placement
    rejection without a config."""
    tid = task_id(task_type.cell, scene.scene_id, task_type.slug, agents, seed)
    rng = seeded_rng(task_type.slug, scene.scene_id, agents, seed)
    try:
        draft = task_type.ground(scene, agents, rng)
    except Ungroundable as exc:
        return Candidate(tid, None, f"placement: {exc}")
    return Candidate(tid, assemble(task_type, scene, agents, seed, draft))


def candidates(stratum: Stratum) -> Iterator[Candidate]:
    """The candidate stream of a stratum."""
    order = list(range(1, SCENES_PER_ROOM + 1))
    # A stratum-specific scene order spreads small strata over different scenes.
    seeded_rng(stratum.task_type, stratum.agents, stratum.room).shuffle(order)
    task_type = TASK_TYPES[stratum.task_type]
    for seed in range(MAX_SEEDS):
        for index in order:
            yield make_candidate(task_type, embedded_scene(stratum.room, index, seed),
                                 stratum.agents, seed)


def judge_all(batch: list[Candidate], pool: Executor | None, backend: str = DEFAULT_BACKEND
              ) -> list[Verdict]:
    """Verdicts for a batch, in order."""
    configs = [c.config for c in batch if c.config is not None]
    check = functools.partial(judge, backend=backend)
    judged = map(check, configs) if pool is None else pool.map(check, configs, chunksize=8)
    return [
        next(judged) if c.config is not None else Verdict(c.task_id, "placement", c.problem)
        for c in batch
    ]


def run_strata(strata: list[Stratum], jobs: int = 1, backend: str = DEFAULT_BACKEND
               ) -> list[StratumResult]:
    """Fill every stratum with candidates that pass the gates."""
    streams = {s: candidates(s) for s in strata}
    results = {s: StratumResult(s) for s in strata}
    workers = jobs or os.cpu_count() or 1
    context = ProcessPoolExecutor(workers) if workers > 1 else nullcontext(None)
    with context as pool:
        while not all(r.full for r in results.values()):
            batch = _next_batch(results, streams)
            verdicts = judge_all([c for _, c in batch], pool, backend)
            for (stratum, candidate), verdict in zip(batch, verdicts):
                _record(results[stratum], candidate, verdict)
    return list(results.values())


def _next_batch(
    results: dict[Stratum, StratumResult], streams: dict[Stratum, Iterator[Candidate]]
) -> list[tuple[Stratum, Candidate]]:
    batch = []
    for stratum, result in results.items():
        if result.full:
            continue
        missing = stratum.count - len(result.kept)
        # A little more than missing: most candidates pass, and a round trip costs a batch.
        drawn = list(islice(streams[stratum], missing + missing // 2 + 2))
        if not drawn:
            raise GenerationError(
                f"{stratum.task_type} ({stratum.agents} agents, {stratum.room}): only "
                f"{len(result.kept)} of {stratum.count} candidates passed the gates"
            )
        batch += [(stratum, c) for c in drawn]
    return batch


def _record(result: StratumResult, candidate: Candidate, verdict: Verdict) -> None:
    if result.full:  # drawn but not needed: not considered
        return
    result.verdicts.append(verdict)
    if verdict.passed and candidate.config is not None:
        result.kept.append(candidate.config)


def generate(jobs: int = 1, backend: str = DEFAULT_BACKEND) -> list[StratumResult]:
    """Run the generator for the whole of `cocobench-full`."""
    return run_strata(full_strata(), jobs, backend)


def rejection_table(results: list[StratumResult]) -> list[dict[str, Any]]:
    """Per task type: candidates considered, kept, and rejected by each gate."""
    rows = []
    for slug, task_type in TASK_TYPES.items():
        mine = [r for r in results if r.stratum.task_type == slug]
        if not mine:
            continue
        verdicts = [v for r in mine for v in r.verdicts]
        row: dict[str, Any] = {
            "task_type": task_type.title,
            "cell": task_type.cell,
            "candidates": len(verdicts),
            "kept": sum(len(r.kept) for r in mine),
        }
        row |= {gate: sum(v.gate == gate for v in verdicts) for gate in GATES}
        rows.append(row)
    return rows
