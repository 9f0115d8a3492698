"""Training-environment throughput: environment steps per second on one core, and reset time.

Plays the PettingZoo parallel environment (`cocobench_agents.envs`) with random legal actions
(drawn from each seat's action mask) under blind conditions, with the prompt text rendered
(``text=True``, what an LLM policy reads) and without (``text=False``, for policies over the
menu and mask), and prints medians over repeated runs:
- environment steps/s (one step: every acting seat's move, landed by the planner's rules) and
  the ratio to AI2-THOR's 13–22 actions/s per process (aim: >= 1,000 with text, >= 5,000
  without), with the steps per CPU-second and the load average beside them (on a shared
  machine the wall-clock rate falls with the load; the CPU rate less, but several-fold at a
  load of 12 or more on 2 cores: compare rates taken at the same load). The environment
  plays the planner's own round: played through its LangGraph graph (63cd55f) a step cost
  several times what it did; a built-in's declared round functions, awaited directly
  (`PlannerSpec.rounds`, `graphs/rounds.py`), took per CPU-second C0_blind 197 -> 503 (text
  on) and 251 -> 555 (off), D1_blind 147 -> 302 and 129 -> 285, C0_image 143 -> 235,
  D1_image 94 -> 141 (the befores at lower loads), the rest of each step now mostly the
  simulator's; the aims are not met yet: see
  docs/environments.md, "Speed";
- landed skill steps/s (a D-round lands up to one call per robot);
- the environment's own time per step: all but the simulator's `Episode.step` (random
  actions are far costlier for the simulator than an oracle's plan: a `Find` of an object
  out of view searches poses), so the figure the environment itself adds is shown apart;
- reset time in milliseconds (aim: < 5 ms).
Image conditions (``C0_image``, ``D1_image``: every step's frames rendered and decoded into
the observation's RGB arrays) are measured too, against their own aim: >= 500 env steps/s.
The first line names the processor and how fast the host runs a fixed Python loop: a figure
is its host's (the same code, the same instructions a step, has run D1_image at 320-340 and
at 637-752 steps per CPU-second on two hosts of this 2-core kind).

With ``--episodes N`` it first plays N whole episodes of ``--memory-source`` (default
cocobench-full, 897 instances drawn at random) under C0_blind and prints the process's
resident memory every 1,000 episodes (aim: flat after warm-up).

With ``--processes N`` it measures in N processes at once, each with its own environment (how a
vectorised trainer runs them), and prints the per-process median and the sum.

Usage: python bench/env.py [--repeats N] [--steps N] [--source SOURCE] [--condition C]…
       [--processes N] [--episodes N [--memory-source SOURCE] [--every N]]
(needs the env extra: pip install -e '.[env]')
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import platform
import statistics
import time
from pathlib import Path

import numpy as np

from benchmark_adapter.episode import Episode
from cocobench_agents.envs import parallel_env
from cocobench_agents.harness.runaway import rss_bytes

SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "cocobench-data" / "tasks"
THOR_ACTIONS_PER_S = (13, 22)
DEFAULT_CONDITIONS = ("C0_blind", "D1_blind", "C0_image", "D1_image")


def aim(condition: str, text: bool) -> int:
    """The env steps/s aimed at: 500 under image conditions, else 1,000 with text, 5,000
    without."""
    if condition.endswith("_image"):
        return 500
    return 1000 if text else 5000


def processor() -> str:
    """The processor's name as the kernel reports it (a virtual machine's may be generic)."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as cpuinfo:
            for line in cpuinfo:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "an unknown processor"


def python_loop_rate(iterations: int = 2_000_000) -> float:
    """Millions of iterations per CPU-second of a fixed pure-Python loop (best of three): how
    fast this host runs the interpreter, so that figures taken on different hosts can be set
    side by side."""
    best = float("inf")
    for _ in range(3):
        started, total = time.process_time(), 0
        for i in range(iterations):
            total += i * i % 7
        best = min(best, time.process_time() - started)
    return iterations / best / 1e6


def resident_mb() -> float:
    """This process's resident memory now, in MB (the runaway watch's reading of /proc; nan
    where /proc cannot tell: not Linux)."""
    rss = rss_bytes(os.getpid())
    return float("nan") if rss is None else rss / 2**20


def memory(source: str, condition: str, episodes: int, every: int) -> None:
    """Play `episodes` whole episodes with random legal moves, printing the resident memory
    every `every` episodes."""
    environment = parallel_env(source, condition=condition)
    rng = np.random.default_rng(0)
    observations, _ = environment.reset(seed=0)
    print(f"memory: {episodes:,} episodes of {source} ({len(environment.configs)} instances), "
          f"{condition}, text on; start {resident_mb():,.0f} MB")
    started, steps = time.perf_counter(), 0
    for played in range(1, episodes + 1):
        while environment.agents:
            observations, *_ = environment.step(random_actions(observations, rng))
            steps += 1
        if played % every == 0:
            print(f"  {played:7,} episodes  RSS {resident_mb():7,.0f} MB  ({steps:,} steps, "
                  f"{time.perf_counter() - started:,.0f} s)", flush=True)
        observations, _ = environment.reset()
    environment.close()


def random_actions(observations: dict, rng: np.random.Generator) -> dict:
    """A random legal move per seat: a menu id on its mask (DONE when only DONE is)."""
    actions = {}
    for seat, observation in observations.items():
        ids = np.flatnonzero(observation["action_mask"]) - 1
        menu = ids[1:] if len(ids) > 1 else ids
        # An index, not rng.choice(menu): choice took 10 µs a call, a tenth of a step.
        choice = int(menu[int(rng.integers(len(menu)))])
        actions[seat] = choice if "sends_message" not in observation else \
            {"action": choice, "message": ""}
    return actions


class SimulatorClock:
    """Times the simulator's part: every `Episode.step` (the class's method, wrapped)."""

    def __init__(self) -> None:
        self.seconds = 0.0
        step = Episode.step

        def timed(*args, **kwargs):
            started = time.perf_counter()
            try:
                return step(*args, **kwargs)
            finally:
                self.seconds += time.perf_counter() - started
        Episode.step = timed


def run(environment, steps: int, seed: int) -> tuple[float, float, int, int, list[float]]:
    """Seconds, CPU seconds, environment steps and landed skill steps of `steps` steps
    (resetting at each episode's end), and the time of each reset."""
    rng = np.random.default_rng(seed)
    resets: list[float] = []
    started = time.perf_counter()
    observations, _ = environment.reset(seed=seed)
    resets.append(time.perf_counter() - started)
    landed = 0
    begun, cpu_begun = time.perf_counter(), time.process_time()
    for _ in range(steps):
        if not environment.agents:
            landed += environment.episode.tools.step_index
            t = time.perf_counter()
            observations, _ = environment.reset()
            resets.append(time.perf_counter() - t)
        observations, *_ = environment.step(random_actions(observations, rng))
    landed += environment.episode.tools.step_index
    return (time.perf_counter() - begun, time.process_time() - cpu_begun, steps, landed,
            resets)


def measure(source: str, condition: str, text: bool, steps: int, repeats: int,
            barrier=None) -> dict[str, float]:
    """Medians of `repeats` runs of `steps` steps: env steps/s, skill steps/s, the env's own
    µs per step, reset ms. With `barrier`, every process warms up, then all measure at once."""
    clock = SimulatorClock()
    environment = parallel_env(source, condition=condition, text=text)
    run(environment, 200, 0)  # warm: every instance's world built once
    if barrier is not None:
        barrier.wait()
    rates, cpu_rates, skill_rates, resets, own = [], [], [], [], []
    for repeat in range(repeats):
        clock.seconds = 0.0
        seconds, cpu_seconds, count, landed, reset_times = run(environment, steps, repeat)
        own.append(1e6 * (seconds - clock.seconds) / count)
        rates.append(count / seconds)
        cpu_rates.append(count / cpu_seconds)
        skill_rates.append(landed / seconds)
        resets.extend(reset_times)
    return {"rate": statistics.median(rates), "cpu_rate": statistics.median(cpu_rates),
            "skill": statistics.median(skill_rates),
            "own": statistics.median(own), "reset": 1000 * statistics.median(resets)}


def _measure_together(processes: int, *args) -> list[dict[str, float]]:
    """`measure` in `processes` processes at once (forked, each with its own environment);
    one that fails breaks the barrier, so the others stop too, and its error is raised."""
    context = multiprocessing.get_context("fork")
    barrier, results = context.Barrier(processes), context.Queue()
    workers = [context.Process(target=_measure_into, args=(results, *args, barrier))
               for _ in range(processes)]
    for worker in workers:
        worker.start()
    figures = [results.get() for _ in workers]
    for worker in workers:
        worker.join()
    failed = [f for f in figures if isinstance(f, str)]
    if failed:
        raise RuntimeError(f"{len(failed)} of {processes} processes failed: {failed[0]}")
    return figures


def _measure_into(results, *args) -> None:
    try:
        results.put(measure(*args))
    except BaseException as exc:  # noqa: BLE001 - said by the parent, which is waiting
        args[-1].abort()  # the others stop waiting at the barrier
        results.put(f"{type(exc).__name__}: {exc}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--steps", type=int, default=2000)
    parser.add_argument("--source", default=str(SHARED))
    parser.add_argument("--condition", action="append",
                        help=f"conditions to measure (default: {', '.join(DEFAULT_CONDITIONS)})")
    parser.add_argument("--processes", type=int, default=1,
                        help="measure in this many processes at once (one environment each) "
                             "and print the per-process median and the sum")
    parser.add_argument("--episodes", type=int, default=0,
                        help="first play this many episodes, printing the resident memory")
    parser.add_argument("--memory-source", default="cocobench-full")
    parser.add_argument("--every", type=int, default=1000,
                        help="print the resident memory every this many episodes")
    args = parser.parse_args()
    if args.episodes:
        memory(args.memory_source, "C0_blind", args.episodes, args.every)
    where = (f"one core (pid {os.getpid()})" if args.processes == 1 else
             f"{args.processes} processes at once on {os.cpu_count()} cores")
    print(f"{where} of {processor()} (a fixed Python loop: {python_loop_rate():.1f} M "
          f"iterations per CPU-s), {args.steps} steps per run, median of {args.repeats} runs, "
          f"source {args.source}")
    for condition in args.condition or DEFAULT_CONDITIONS:
        for text in (True, False):
            task = (args.source, condition, text, args.steps, args.repeats)
            if args.processes == 1:
                figures = measure(*task)
                total = ""
            else:
                each = _measure_together(args.processes, *task)
                figures = {k: statistics.median(f[k] for f in each) for k in each[0]}
                total = f"  all {args.processes}: {sum(f['rate'] for f in each):9,.0f} steps/s"
            rate = figures["rate"]
            low, high = (rate / a for a in reversed(THOR_ACTIONS_PER_S))
            print(f"{condition:9} text={'on ' if text else 'off'}  env steps/s "
                  f"{rate:8,.0f} (aim >= {aim(condition, text):,}; "
                  f"{figures['cpu_rate']:,.0f} per CPU-s, load {os.getloadavg()[0]:.1f})  "
                  f"x{low:,.0f}–{high:,.0f} AI2-THOR  "
                  f"skill steps/s {figures['skill']:8,.0f}  env's own "
                  f"{figures['own']:5.0f} µs/step  reset {figures['reset']:6.2f} ms "
                  f"(aim < 5){total}")


if __name__ == "__main__":
    main()
