"""Every instance of `cocobench-full` and every shared config, played to its end by the
built-in models, stays within stated bounds (issue 24: one `random` episode of the paper's
suite grew without bound and hung the run).

Each instance runs under image and under blind observation with `random` at three seeds (seed
0 with the centralized planner, as `cocobench run` does; seeds 1 and 2 with the decentralized
planners, without and with broadcast messages) and with `greedy` (centralized). The random
streams are keyed as the harness keys them, so the sweep includes the very episode of the
issue (`random`, `C0_image`, `C_D2__EmbBedroom11__load_in_order_4agent_seed0`).

The episodes run in worker processes (one per core, two to four) whose address space is
capped with `RLIMIT_AS`, so a runaway fails this test with a `MemoryError` instead of taking
the machine down, and `SIGALRM` stops an episode that never ends (one that never yields
included). Measured on the 2-core development machine, shared with other work: the 7,464
episodes take 470-560 s of CPU in all; 7 minutes of wall time at a load of 3-4 (34 minutes at
a load of 12). A worker holds up to about 256 MB between episodes, most of it the loaded suites
and the simulator's bounded caches; the memory bound is on each episode's own peak above what
its worker held when it started.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import multiprocessing
import resource
import signal
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from benchmark_adapter.sim.embedded import EmbeddedController
from benchmark_adapter.sim.embedded.render import merge_agent_frames
from benchmark_adapter.tasks import TaskConfig, load_tasks
from benchmark_adapter.trajectory import PROMPTS_FIELD
from cocobench_agents.episode_runner import EpisodeSpec, run_episode
from cocobench_agents.models import ModelPool, ModelSettings
from cocobench_agents.runfolder.episode_key import EpisodeKey
from tests.paths import SHARED_TASKS

# -- the stated bounds ------------------------------------------------------------------------
# How far a worker's resident memory peaked, during one episode, above what it held when the
# episode started (the kernel's peak, reset before each episode). Relative: what a worker
# holds before (imports, suites, the simulator's bounded caches) differs between environments,
# and a fresh venv's workers peaked 450 MB higher while importing.
PEAK_RSS_MB = 300
FRAME_BYTES = 1_000_000  # any agent's frame, or the team's merged frame, as a VLM gets it
PROMPT_CHARS = 24_000  # any prompt a model gets
EPISODE_SECONDS = 60  # one episode, start to trajectory (a healthy one takes well under 1 s)
ADDRESS_SPACE_HEADROOM = 1 << 30  # RLIMIT_AS: the worker's address space at start + 1 GiB

SOURCES = {"cocobench-full": "cocobench-full", "shared": SHARED_TASKS}
RUNS = (  # (model, planner, condition label as `cocobench run` names it)
    ("random", "centralized", "C0"),
    ("random:1", "decentralized", "D0"),
    ("random:2", "decentralized-broadcast", "D1"),
    ("greedy", "centralized", "C0"),
)


@dataclass(frozen=True)
class Job:
    """One episode of the sweep: an instance (by source and index), a model and a view."""

    source: str
    index: int
    model: str
    planner: str
    condition: str
    budget: int


@dataclass(frozen=True)
class Outcome:
    """What one episode used; `error` when it did not finish."""

    job: Job
    task_id: str
    seconds: float
    rss_mb: float
    steps: int = 0
    prompt_chars: int = 0
    frame_bytes: int = 0
    error: str = ""


class EpisodeOverran(BaseException):
    """Raised by SIGALRM in the worker (a BaseException: no `except Exception` in the code
    under test can swallow it)."""


_CONFIGS: dict[str, list[TaskConfig]] = {}
_BASE_RSS_MB = [0.0]  # the worker's resident memory when its current episode started


def _sources() -> dict[str, list[TaskConfig]]:
    return {name: load_tasks(source) for name, source in SOURCES.items()
            if name != "shared" or SHARED_TASKS.exists()}


def _start_worker() -> None:
    """Cap the worker's address space and arm the episode alarm."""
    limit = _address_space() + ADDRESS_SPACE_HEADROOM
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    signal.signal(signal.SIGALRM, _overran)


def _address_space() -> int:
    """This process's virtual memory size in bytes (Linux)."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmSize:"):
            return int(line.split()[1]) * 1024
    raise RuntimeError("no VmSize in /proc/self/status")


def _overran(signum: int, frame: Any) -> None:
    raise EpisodeOverran("still running when the episode alarm rang")


def _rss_mb() -> float:
    """How far this worker's resident memory peaked above the start of its episode."""
    return _status_mb("VmHWM") - _BASE_RSS_MB[0]


def _start_episode_peak() -> None:
    """Reset the kernel's record of this process's peak (Linux 4.0+) and note where it
    starts."""
    Path("/proc/self/clear_refs").write_text("5")
    _BASE_RSS_MB[0] = _status_mb("VmRSS")


def _status_mb(field: str) -> float:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith(f"{field}:"):
            return int(line.split()[1]) / 1024
    raise RuntimeError(f"no {field} in /proc/self/status")


def guarded(job: Job, task_id: str, play: Callable[[], Outcome],
            seconds: int = EPISODE_SECONDS) -> Outcome:
    """`play()` under the episode alarm; a runaway, or any error, becomes an `Outcome`
    naming the cause (the sweep reports every breach, not only the first)."""
    start = time.perf_counter()
    _start_episode_peak()
    signal.alarm(seconds)
    try:
        return play()
    except (Exception, EpisodeOverran) as exc:  # noqa: BLE001 - MemoryError included
        return Outcome(job, task_id, time.perf_counter() - start, _rss_mb(), error=repr(exc))
    finally:
        signal.alarm(0)


def play(job: Job) -> Outcome:
    """Run one job in a worker (see `_start_worker`)."""
    if not _CONFIGS:  # once per worker
        _CONFIGS.update(_sources())
    config = _CONFIGS[job.source][job.index]
    return guarded(job, config.task_id, lambda: _episode(job, config))


def _episode(job: Job, config: TaskConfig) -> Outcome:
    start = time.perf_counter()
    key = EpisodeKey(job.model, job.condition, config.task_id).folder()
    spec = EpisodeSpec(config, planner=job.planner, models={"*": job.model},
                       obs_mode=job.condition.partition("_")[2],
                       episode_key=key.removeprefix("episodes/"))
    controller = EmbeddedController(config)
    document, result = asyncio.run(run_episode(spec, ModelPool(ModelSettings()),
                                               controller=controller))
    frames = _frames(controller, config) if spec.obs_mode == "image" else []
    prompts = document.get(PROMPTS_FIELD, {}).values()
    return Outcome(job, config.task_id, time.perf_counter() - start, _rss_mb(),
                   steps=result.num_steps,
                   prompt_chars=max((len(p) for p in prompts), default=0),
                   frame_bytes=max((len(f) for f in frames), default=0))


def _frames(controller: EmbeddedController, config: TaskConfig) -> list[bytes]:
    """Every agent's frame of the final state, and the team's merged one (the built-in
    models read no images, so the episode itself renders none)."""
    own = [(agent, controller.frame(i)) for i, agent in enumerate(config.agent_ids)]
    return [frame for _, frame in own] + [merge_agent_frames(own)]


def jobs(configs: dict[str, list[TaskConfig]]) -> list[Job]:
    """Every instance × run × view, longest budget first (so both cores finish together)."""
    out = [Job(source, index, model, planner, f"{label}_{view}", config.budget)
           for source, listed in configs.items() for index, config in enumerate(listed)
           for model, planner, label in RUNS for view in ("image", "blind")]
    return sorted(out, key=lambda j: -j.budget)


def breaches(outcome: Outcome) -> Iterator[str]:
    """Each stated bound `outcome` breaks, in words."""
    where = f"{outcome.job.model} {outcome.job.condition} {outcome.task_id}"
    checks = (
        (outcome.error, f"ended with {outcome.error}"),
        (outcome.rss_mb > PEAK_RSS_MB,
         f"peak RSS {outcome.rss_mb:.0f} MB above the episode's start > {PEAK_RSS_MB}"),
        (outcome.frame_bytes > FRAME_BYTES, f"a {outcome.frame_bytes}-byte frame"),
        (outcome.prompt_chars > PROMPT_CHARS, f"a {outcome.prompt_chars}-character prompt"),
        (outcome.seconds > EPISODE_SECONDS, f"took {outcome.seconds:.1f} s"),
        (outcome.steps > outcome.job.budget, f"{outcome.steps} steps > budget"),
    )
    for broken, words in checks:
        if broken:
            yield f"{where}: {words}"


def sweep(run: Callable[[Job], Outcome], planned: list[Job], workers: int) -> list[Outcome]:
    """`run` each job in `workers` fresh processes (spawned: nothing of this one leaks in)."""
    context = multiprocessing.get_context("spawn")
    with concurrent.futures.ProcessPoolExecutor(workers, mp_context=context,
                                                initializer=_start_worker) as pool:
        return list(pool.map(run, planned, chunksize=8))


@pytest.mark.slow
def test_every_episode_of_the_suites_stays_within_bounds():
    configs = _sources()
    planned = jobs(configs)
    assert len(planned) == 8 * sum(len(listed) for listed in configs.values())
    outcomes = sweep(play, planned, workers=max(2, min(4, multiprocessing.cpu_count())))
    assert len(outcomes) == len(planned)
    broken = [words for outcome in outcomes for words in breaches(outcome)]
    assert not broken, f"{len(broken)} breaches, first: " + "\n".join(broken[:20])
    issue = next(o for o in outcomes if o.task_id ==
                 "C_D2__EmbBedroom11__load_in_order_4agent_seed0"
                 and o.job.model == "random" and o.job.condition == "C0_image")
    assert issue.steps == issue.job.budget and issue.frame_bytes > 0


# -- the sweep's guards catch runaways ----------------------------------------------------------

PLANTED = Job("planted", 0, "none", "none", "C0_blind", 1)


def _allocate_forever(job: Job) -> Outcome:
    def hog() -> Outcome:
        hoard = []
        while True:
            hoard.append(bytearray(16 << 20))

    return guarded(job, "allocates", hog)


def _spin_forever(job: Job) -> Outcome:
    def spin() -> Outcome:
        while True:
            pass

    return guarded(job, "spins", spin, seconds=1)


@pytest.mark.slow
def test_the_sweep_records_runaways_instead_of_hanging():
    allocates, spins = sweep(_allocate_forever, [PLANTED], 1) + sweep(_spin_forever, [PLANTED], 1)
    assert allocates.error.startswith("MemoryError")
    assert spins.error.startswith("EpisodeOverran") and 1 <= spins.seconds < 30
    assert [*breaches(spins)] == ["none C0_blind spins: ended with " + spins.error]
