"""Verifying a whole run folder: every episode's verdict (`replay.verify_episode`), in
parallel processes where the run is large enough to pay for them."""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import multiprocessing
import time
from collections import Counter
from collections.abc import Iterable, Iterator, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from benchmark_adapter.tasks import available_suites, load_tasks
from cocobench_agents.harness.workers import available_cores
from cocobench_agents.runfolder import EpisodeKey, RunFolder, RunFolderError, result_key
from cocobench_agents.verify.bundle import bundle_problems, open_bundle, settings_labels
from cocobench_agents.verify.errors import VerifyError, VerifyStopped
from cocobench_agents.verify.replay import Verdict, verify_episode

#: Episodes one worker process takes at a time (few enough to keep both cores busy to the
#: end, enough that a chunk's hand-off costs little).
CHUNK = 64
#: Below this many episodes one process does it all: forking costs more than it saves.
PARALLEL_FROM = 128


@dataclass
class RunVerification:
    """The verdict on every episode of one run, and what kept others from being judged."""

    path: Path
    verdicts: list[tuple[EpisodeKey, Verdict]] = field(default_factory=list)
    #: Problems of the run's files (invalid result lines, …): each fails the verification.
    problems: list[str] = field(default_factory=list)
    elapsed_s: float = 0.0
    processes: int = 1
    #: Settings of a bundle that are not the reference's (``max_steps=10``): shown, never
    #: mixed in with reference rows.
    labels: list[str] = field(default_factory=list)

    @property
    def counts(self) -> Counter[str]:
        return Counter(verdict.status for _, verdict in self.verdicts)

    @property
    def ok(self) -> bool:
        """Whether every episode verifies, and nothing else is wrong."""
        return not self.problems and all(v.status == "verified" for _, v in self.verdicts)

    def as_json(self) -> dict[str, Any]:
        return {"path": str(self.path), "ok": self.ok, "counts": dict(self.counts),
                "problems": self.problems, "labels": self.labels,
                "elapsed_s": round(self.elapsed_s, 3),
                "episodes": [{**key.as_dict(), **dataclasses.asdict(verdict)}
                             for key, verdict in self.verdicts]}


def reference_configs(sources: Iterable[str | Path] = ()) -> dict[str, dict[str, Any]]:
    """The reference's own task configs by task id: every built-in suite's, and those of
    `sources` (files or folders: the official configs, say). An instance found here is
    verified against this config, whatever its run says it ran."""
    configs = dict(_suite_configs())
    for source in sources:
        for config in load_tasks(source):
            configs.setdefault(config.task_id, config.to_json_dict())
    return configs


@functools.cache
def _suite_configs() -> dict[str, dict[str, Any]]:
    # Read once per process (a second, for cocobench-full's 897): the package's own files.
    return {config.task_id: config.to_json_dict()
            for suite in available_suites() for config in load_tasks(suite)}


def verify_run(path: str | Path, *, reference: Mapping[str, Mapping[str, Any]] | None = None,
               jobs: int | None = None) -> RunVerification:
    """Replay every episode of the run folder at `path` (`RunFolderError` when it is not
    one); `reference`: the configs reference instances must carry (default: the built-in
    suites'); `jobs`: processes (default: the cores this process may use). `VerifyStopped`
    when a worker process dies before its episodes are judged."""
    started = time.perf_counter()
    folder = RunFolder(path)
    record = folder.run_record()
    scan = folder.scan_results(check_trajectories=True)
    outcome = RunVerification(Path(path), problems=list(scan.problems))
    if scan.torn_tail:
        outcome.problems.append(f"{folder.results_path}: an incomplete last line")
    lines = list(scan.latest.values())
    if not lines:
        outcome.problems.append(f"{folder.results_path}: no result lines")
    if reference is None:
        reference = reference_configs()
    stable_ids = bool((record.get("request") or {}).get("stable_ids"))
    chunks = [lines[i:i + CHUNK] for i in range(0, len(lines), CHUNK)]
    jobs = max(1, min(jobs or available_cores(), len(chunks)))
    tasks = [(str(path), chunk, _needed(reference, chunk), stable_ids) for chunk in chunks]
    if jobs == 1 or len(lines) < PARALLEL_FROM:
        results = [verify_lines(*task) for task in tasks]
    else:
        outcome.processes = jobs
        context = multiprocessing.get_context("fork" if "fork" in
                                              multiprocessing.get_all_start_methods()
                                              else "spawn")
        try:
            with ProcessPoolExecutor(jobs, mp_context=context) as pool:
                results = list(pool.map(verify_lines, *zip(*tasks)))
        except BrokenProcessPool:  # a worker killed (SIGKILL, out of memory): judged nothing
            raise VerifyStopped("verify stopped: a worker process ended abruptly (killed, or "
                                "out of memory); no verdict: run it again") from None
    outcome.verdicts = [pair for result in results for pair in result]
    outcome.elapsed_s = time.perf_counter() - started
    return outcome


def verify_lines(path: str, lines: Sequence[Mapping[str, Any]],
                 reference: Mapping[str, Mapping[str, Any]], stable_ids: bool
                 ) -> list[tuple[EpisodeKey, Verdict]]:
    """The verdicts on some result lines of the run folder at `path` (a worker's share)."""
    folder = RunFolder(path)
    verdicts = []
    for line in lines:
        key = result_key(line)
        try:
            document = None if line.get("infra_error") else folder.trajectory(line)
            prompts = folder.prompts(line)  # none kept: every prompt hash is unmatched
        except RunFolderError as exc:
            verdicts.append((key, Verdict("mismatch", field="trajectory", detail=str(exc))))
            continue
        verdicts.append((key, verify_episode(document, line, prompts=prompts,
                                             reference=reference, stable_ids=stable_ids)))
    return verdicts


def _needed(reference: Mapping[str, Mapping[str, Any]], lines: Sequence[Mapping[str, Any]]
            ) -> dict[str, Mapping[str, Any]]:
    """The reference configs of `lines`' instances: what one chunk's worker needs."""
    return {line["task_id"]: reference[line["task_id"]] for line in lines
            if line["task_id"] in reference}



def verify_source(path: str | Path, *, reference: Mapping[str, Mapping[str, Any]] | None = None,
                  jobs: int | None = None) -> RunVerification:
    """`verify_run` on a run folder, or on a submission bundle (``.cocobench.tar.gz``),
    unpacked as data only and checked against its manifest: a bundle that does not cover
    what it declares is refused (its `problems`). Settings that are not the reference's are
    the outcome's `labels`. `VerifyError` for a path that is neither, or a bundle refused
    whole."""
    with opened(path) as (folder, manifest):
        return verify_opened(path, folder, manifest, reference=reference, jobs=jobs)


@contextlib.contextmanager
def opened(path: str | Path) -> Iterator[tuple[Path, dict[str, Any] | None]]:
    """A run folder as it is (no manifest), or a bundle unpacked for the duration, with its
    manifest (`bundle.open_bundle`)."""
    source = Path(path)
    if source.is_dir():
        yield source, None
    elif source.is_file():
        with open_bundle(source) as unpacked:
            yield unpacked
    else:
        raise VerifyError(f"{path}: no such run folder or bundle")


def verify_opened(path: str | Path, folder: Path, manifest: Mapping[str, Any] | None, *,
                  reference: Mapping[str, Mapping[str, Any]] | None = None,
                  jobs: int | None = None) -> RunVerification:
    """The verification of an `opened` source: its episodes, and a bundle's own checks."""
    problems = bundle_problems(folder, manifest) if manifest is not None else []
    outcome = verify_run(folder, reference=reference, jobs=jobs)
    outcome.path, outcome.labels = Path(path), settings_labels(folder)
    outcome.problems = [p.replace(str(folder), str(path)) for p in problems + outcome.problems]
    return outcome
