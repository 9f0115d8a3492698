"""How local runs scale with worker processes.

Runs `cocobench run --suite SUITE --model greedy --baselines --workers W --jobs 2W` (built-in
models only: the run is CPU-bound, the case worker processes exist for) for W = 1, 2, 4, … up
to this machine's cores, and prints the median wall time of each (the whole command, as a user
waits for it), its speed-up over one worker and that speed-up as a share of linear. Aim
(issue 24): `cocobench-full` at >= 12x on 16 cores (75 % of linear), >= 1.8x on 2 cores.

With --profile it instead runs the suite once per worker count through the engine, its events
timed, and splits each run into its serial start (interpreter, imports, planning, the pool's
start), its parallel phase, that phase's tail (worker-seconds left idle once the queue is
empty) and its serial end, each in wall seconds and in the CPU seconds of the process that
plans and supervises (a shared machine's load distorts CPU seconds less). From the one-worker
profile it then computes the speed-up on --cores cores (`predict`): the serial CPU seconds as
measured, and the episodes' CPU seconds run through a simulation of the queue on that many
workers (`makespan`), which is Amdahl's law with the tail counted rather than guessed.

Usage: python bench/scaling.py [--suite cocobench-240]… [--repeats 3] [--workers 1 2 4]…
       python bench/scaling.py --profile [--suite cocobench-full] [--workers 1 2] [--cores 16]
                               [--limit N]
"""

from __future__ import annotations

import argparse
import functools
import itertools
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from collections import deque
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

from cocobench_agents.harness.workers import available_cores


def worker_counts(cores: int) -> list[int]:
    """1, 2, 4, … up to `cores`, and `cores` itself."""
    counts, count = [], 1
    while count < cores:
        counts.append(count)
        count *= 2
    return [*counts, cores]


def run_arguments(suite: str, workers: int, out: Path, limit: int | None = None) -> list[str]:
    """`cocobench run`'s arguments for a run of `suite` (its first `limit` instances) with
    `workers` processes."""
    return ["run", "--suite", suite, "--model", "greedy", "--baselines", "--workers",
            str(workers), "--jobs", str(2 * workers), "--out", str(out),
            *(["--limit", str(limit)] if limit else [])]


def run_environment(suite: str) -> dict[str, str]:
    """The environment of the measured runs of `suite`: bytecode cached as an installed
    package and its interpreter have it. Where PYTHONDONTWRITEBYTECODE is set (this
    project's shared machines) every run would compile the package's sources again: 0.18 s
    of CPU more in a run's serial start (median of 5, load 8-10), a cost no user's install
    pays. The bytecode goes to a folder of this process (PYTHONPYCACHEPREFIX), which Python
    then reads for every module, the standard library's and the installed packages' too:
    the package is compiled once, and one run of the suite's first instance compiles the
    rest of what a run imports (else the first measured run compiles it: 1.5-1.8 CPU s of
    its imports, more than the imports themselves, by a --limit 2 profile at load 2-4)."""
    env = _environment(_bytecode_folder().name)
    _warm_up(suite, env["PYTHONPYCACHEPREFIX"])
    return env


@functools.cache
def _bytecode_folder() -> tempfile.TemporaryDirectory:
    folder = tempfile.TemporaryDirectory(prefix="scaling-pycache-")
    subprocess.run([sys.executable, "-m", "compileall", "-q", "cocobench_agents",
                    "benchmark_adapter"], cwd=Path(__file__).resolve().parent.parent,
                   env=_environment(folder.name), check=True, capture_output=True)
    return folder


@functools.cache
def _warm_up(suite: str, pycache: str) -> None:
    """One unmeasured run of `suite`'s first instance, its bytecode written to `pycache`."""
    with tempfile.TemporaryDirectory() as tmp:
        command = [sys.executable, "-m", "cocobench_agents.cli",
                   *run_arguments(suite, 1, Path(tmp) / "run", limit=1)]
        done = subprocess.run(command, capture_output=True, text=True,
                              env=_environment(pycache))
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(command)} failed ({done.returncode}):\n{done.stderr}")


def _environment(pycache: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    return {**env, "PYTHONPYCACHEPREFIX": pycache, "NO_COLOR": "1"}


def wall_time(suite: str, workers: int) -> float:
    """Seconds one whole run takes, in a fresh run folder."""
    with tempfile.TemporaryDirectory() as tmp:
        command = [sys.executable, "-m", "cocobench_agents.cli",
                   *run_arguments(suite, workers, Path(tmp) / "run")]
        env = run_environment(suite)  # before the clock starts: it may warm up
        started = time.perf_counter()
        done = subprocess.run(command, capture_output=True, text=True, env=env)
        elapsed = time.perf_counter() - started
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(command)} failed ({done.returncode}):\n{done.stderr}")
    return elapsed


# -- --profile ------------------------------------------------------------------------------

#: The profiled run: `cocobench run` as `wall_time` runs it, in a child process whose engine
#: `run` is wrapped to time the events it tells the command (wall and this process's CPU
#: seconds); the workers' CPU seconds are read once they ended.
PROFILED_RUN = """
import json, resource, sys, time
marks = {"interpreter": [time.time(), time.process_time()]}
from cocobench_agents import cli
from cocobench_agents.engine import events
from cocobench_agents.engine import run as engine
dump, argv = sys.argv[1], sys.argv[2:]
starts, ends, command_run = {}, {}, engine.run
marks["imported"] = [time.time(), time.process_time()]
def key(k):
    return "/".join(str(k.get(f)) for f in ("model", "condition", "arm", "task_id", "epoch"))
def timed_run(request, *, on_event=None, **options):
    def both(event):
        mark = [time.time(), time.process_time()]
        if isinstance(event, events.RunStarted):
            marks["planned"] = mark
        elif isinstance(event, events.EpisodeStarted):
            starts[key(event.key)] = mark
        elif isinstance(event, events.EpisodeRecorded):
            ends[key(event.record)] = mark
        if on_event is not None:
            on_event(event)
    return command_run(request, on_event=both, **options)
engine.run = timed_run
code = cli.main(argv)
children = resource.getrusage(resource.RUSAGE_CHILDREN)
json.dump({"marks": marks, "returned_cpu": time.process_time(),
           "workers_cpu": children.ru_utime + children.ru_stime,
           "episodes": [[starts[k], ends[k]] for k in starts]}, open(dump, "w"))
sys.exit(code)
"""


@dataclass(frozen=True)
class Profile:
    """One run's phases: wall seconds, and CPU seconds of the supervisor (the process that
    plans, starts the pool and writes the result lines)."""

    workers: int
    wall_s: float
    start_s: float  # up to the first episode's start
    start_cpu_s: float
    phases: dict[str, tuple[float, float]]  # the start's parts: (wall, CPU) seconds
    parallel_s: float  # first start to last result line
    tail_idle_s: float  # worker-seconds idle after the last start
    end_s: float  # last result line to the process's exit
    end_cpu_s: float
    supervisor_cpu_s: float  # while the workers run
    workers_cpu_s: float
    works: tuple[float, ...]  # each episode's CPU seconds, in start order (one worker)

    @property
    def serial_cpu_s(self) -> float:
        return self.start_cpu_s + self.end_cpu_s


def profiled_run(suite: str, workers: int, limit: int | None = None) -> Profile:
    """Run `suite` (its first `limit` instances) once with `workers` processes and time its
    phases."""
    with tempfile.TemporaryDirectory() as tmp:
        dump = Path(tmp) / "profile.json"
        env = run_environment(suite)  # before the clock starts: it may warm up
        spawned = time.time()
        done = subprocess.run([sys.executable, "-c", PROFILED_RUN, str(dump),
                               *run_arguments(suite, workers, Path(tmp) / "run", limit)],
                              capture_output=True, text=True, env=env)
        exited = time.time()
        if done.returncode != 0:
            raise SystemExit(f"profiled run failed ({done.returncode}):\n{done.stderr}")
        data = json.loads(dump.read_text())
    episodes = sorted(data["episodes"])  # by start
    first, last_start = episodes[0][0], episodes[-1][0]
    last = max(end for _, end in episodes)
    # +1 at each start, -1 at each end: how many episodes are in flight when
    timeline = sorted([(s[0], 1) for s, _ in episodes] + [(e[0], -1) for _, e in episodes])
    marks = [[spawned, 0.0], *data["marks"].values(), first]
    phases = {name: (b[0] - a[0], b[1] - a[1]) for name, (a, b) in zip(
        ("interpreter", "imports", "planning", "pool start"), itertools.pairwise(marks),
        strict=True)}
    return Profile(
        workers=workers, wall_s=exited - spawned,
        start_s=first[0] - spawned, start_cpu_s=first[1], phases=phases,
        parallel_s=last[0] - first[0],
        tail_idle_s=_idle_worker_s(timeline, workers, since=last_start[0]),
        end_s=exited - last[0], end_cpu_s=data["returned_cpu"] - last[1],
        supervisor_cpu_s=last[1] - first[1], workers_cpu_s=data["workers_cpu"],
        works=_works(timeline, episodes, data["workers_cpu"]) if workers == 1 else ())


def _in_flight(timeline: list[tuple[float, int]]) -> Iterator[tuple[float, float, int]]:
    """(from, to, episodes in flight) for each piece of the timeline."""
    running = 0
    for (t, change), (t_next, _) in itertools.pairwise(timeline):
        running += change
        yield t, t_next, running


def _idle_worker_s(timeline: list[tuple[float, int]], workers: int, since: float) -> float:
    """Worker-seconds with no episode in flight after `since` (the supervisor hands the next
    episode to the least busy worker, so `n` in flight keep min(n, W) workers busy)."""
    return sum((workers - min(workers, n)) * (b - max(a, since))
               for a, b, n in _in_flight(timeline) if b > since)


def _works(timeline: list[tuple[float, int]], episodes: list, cpu_s: float
           ) -> tuple[float, ...]:
    """Each episode's CPU seconds in a one-worker run, in start order: its share of the
    worker while in flight (the episodes in flight share it equally), scaled so that they
    add up to the worker's CPU seconds (what load added is spread evenly)."""
    pieces = [(a, b, n) for a, b, n in _in_flight(timeline) if n]
    shares = [sum((min(b, end[0]) - max(a, start[0])) / n
                  for a, b, n in pieces if b > start[0] and a < end[0])
              for start, end in episodes]
    return tuple(w * cpu_s / sum(shares) for w in shares)


def makespan(works: Sequence[float], workers: int, slots: int) -> float:
    """Seconds to run `works` (CPU seconds, in hand-out order) on `workers` processes of
    `slots` episodes each, as the supervisor hands them out (the next episode to the least
    busy worker with a free slot) and a worker's event loop runs them (sharing its core)."""
    queue, running, now = deque(works), [[] for _ in range(workers)], 0.0
    while queue or any(running):
        while queue:
            free = [r for r in running if len(r) < slots]
            if not free:
                break
            min(free, key=len).append(queue.popleft())
        step = min(min(r) * len(r) for r in running if r)  # to the next episode's end
        for r in running:
            r[:] = [w - step / len(r) for w in r if w - step / len(r) > 1e-9]
        now += step
    return now


def pool_start_per_worker(workers: int) -> float:
    """CPU seconds the supervisor spends starting each further worker: the pool-start phase
    of the demo suite (12 episodes) with one worker and with `workers` (at most 12)."""
    workers = min(workers, 12)
    one, many = (profiled_run("demo", w).phases["pool start"][1] for w in (1, workers))
    return max(0.0, (many - one) / (workers - 1)) if workers > 1 else 0.0


def predict(one: Profile, per_worker_s: float, cores: int) -> tuple[float, float]:
    """Seconds on `cores` cores with one worker and with `cores` workers (--jobs 2W): the
    serial start and end in CPU seconds as measured with one worker, plus the pool's start
    of each further worker, then the episodes' CPU seconds through `makespan`; with as many
    workers as cores the supervisor's CPU seconds come out of the workers' time, and bound
    the parallel phase from below."""
    steal = 1 + one.supervisor_cpu_s / one.workers_cpu_s
    t_one = one.serial_cpu_s + makespan(one.works, 1, 2)
    parallel = makespan([w * steal for w in one.works], cores, 2)
    # The supervisor handles every result line: the phase cannot end before it has.
    t_many = one.serial_cpu_s + per_worker_s * (cores - 1) + max(parallel,
                                                                 one.supervisor_cpu_s)
    return t_one, t_many


def profile(suite: str, counts: list[int], cores: int, limit: int | None = None) -> None:
    """Profile one run per worker count; print each phase and the predicted speed-ups."""
    part = f" (first {limit} instances)" if limit else ""
    print(f"{suite}{part}: greedy + baselines, --jobs 2W; load average "
          f"{os.getloadavg()[0]:.1f}\nwall seconds (supervisor CPU seconds in brackets)")
    print(f"{'workers':>7} {'wall':>6} {'start':>12} {'parallel':>8} {'tail idle':>10} "
          f"{'end':>11} {'supervisor':>10} {'workers':>8}")
    profiles = {}
    for workers in counts:
        p = profiles[workers] = profiled_run(suite, workers, limit)
        print(f"{workers:>7} {p.wall_s:>6.1f} {p.start_s:>5.1f} ({p.start_cpu_s:4.1f}) "
              f"{p.parallel_s:>8.1f} {p.tail_idle_s / workers:>9.1f}s {p.end_s:>4.1f} "
              f"({p.end_cpu_s:4.1f}) {p.supervisor_cpu_s:>9.1f}s {p.workers_cpu_s:>7.1f}s",
              flush=True)
        print(" " * 8 + "start: " + ", ".join(f"{name} {wall:.1f} ({cpu:.1f})"
                                              for name, (wall, cpu) in p.phases.items()))
    one = profiles.get(1)
    if one is None:
        return
    base = one.serial_cpu_s + one.workers_cpu_s
    per_worker_s = pool_start_per_worker(cores)
    print(f"shares of the one-worker CPU time ({base:.1f} s): serial start "
          f"{one.start_cpu_s / base:.2%}, serial end {one.end_cpu_s / base:.2%}, supervisor "
          f"while the worker runs {one.supervisor_cpu_s / base:.2%}; pool start "
          f"{per_worker_s * 1e3:.0f} ms CPU per further worker; {len(one.works)} episodes, "
          f"median {statistics.median(one.works):.3f} s, longest {max(one.works):.2f} s CPU")
    for target in sorted({2, cores}):
        t_one, t_many = predict(one, per_worker_s, target)
        print(f"predicted on {target} cores: {t_one:.1f} s with 1 worker, {t_many:.1f} s "
              f"with {target}: {t_one / t_many:.2f}x ({t_one / t_many / target:.0%} of linear)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--suite", action="append", dest="suites",
                        help="suite to run (repeatable; default: cocobench-240 and "
                             "cocobench-full; with --profile cocobench-full)")
    parser.add_argument("--repeats", type=int, default=3, help="runs per point (median)")
    parser.add_argument("--workers", type=int, nargs="+",
                        help="worker counts (default: 1, 2, 4, … up to the cores; with "
                             "--profile 1)")
    parser.add_argument("--profile", action="store_true",
                        help="time each run's phases and predict the speed-up on --cores")
    parser.add_argument("--cores", type=int, default=16,
                        help="the machine --profile predicts for (default 16)")
    parser.add_argument("--limit", type=int,
                        help="--profile: the suite's first N instances only")
    args = parser.parse_args()
    if args.profile:
        for suite in args.suites or ["cocobench-full"]:
            profile(suite, args.workers or [1], args.cores, args.limit)
        return
    cores = available_cores()
    counts = args.workers or worker_counts(cores)
    print(f"{cores} cores; greedy + baselines; --jobs 2W; median of {args.repeats}")
    for suite in args.suites or ["cocobench-240", "cocobench-full"]:
        print(f"\n{suite}\n{'workers':>8} {'wall s':>8} {'speed-up':>9} {'of linear':>10}")
        base = None
        for workers in counts:
            median = statistics.median(wall_time(suite, workers) for _ in range(args.repeats))
            base = base or median * counts[0]  # one worker's time (or the first point's × W)
            speedup = base / median
            print(f"{workers:>8} {median:>8.2f} {speedup:>8.2f}x {speedup / workers:>9.0%}",
                  flush=True)


if __name__ == "__main__":
    main()
