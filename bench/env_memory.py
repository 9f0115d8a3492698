"""Training-environment memory over many episodes: the resident memory every 1,000 episodes.

Plays whole episodes of one environment (default: cocobench-full's 897 instances, drawn at
random by the environment's seeded generator; C0_blind, prompt text on) with random legal
moves, and prints after every `--every` episodes the process's resident memory (RSS), the
change since the last line, the episodes per second so far, and the Python object types
whose live counts grew most since the last line (`gc.get_objects()`), which is where a leak
of Python objects shows. With `--tracemalloc` it also prints the source lines whose
allocations grew most since the last line (several times slower: for hunting a leak, not
for the curve). Aim: flat after warm-up (the environment keeps `KEPT_EPISODES` instances
built; the simulator's caches are bounded).

Usage: python bench/env_memory.py [--episodes N] [--every N] [--source SOURCE]
       [--condition C] [--no-text] [--minutes M] [--tracemalloc]
(needs the env extra: pip install -e '.[env]')
"""

from __future__ import annotations

import argparse
import collections
import gc
import sys
import time
import tracemalloc
from pathlib import Path

import numpy as np

from cocobench_agents.envs import parallel_env

sys.path.insert(0, str(Path(__file__).resolve().parent))
from env import random_actions, resident_mb  # (the bench folder is no package: on the path above)


def object_counts() -> collections.Counter:
    """Live objects the garbage collector tracks, by type name (after a full collection)."""
    gc.collect()
    return collections.Counter(type(o).__qualname__ for o in gc.get_objects())


def grown(after: collections.Counter, before: collections.Counter, top: int) -> str:
    """The `top` types whose counts grew most, as 'name +n'."""
    growth = [(after[name] - before[name], name) for name in after]
    growth = sorted((g for g in growth if g[0] > 0), reverse=True)[:top]
    return ", ".join(f"{name} +{count:,}" for count, name in growth) or "none"


def play(source: str, condition: str, text: bool, episodes: int, every: int,
         minutes: float | None, trace: bool) -> None:
    environment = parallel_env(source, condition=condition, text=text)
    rng = np.random.default_rng(0)
    observations, _ = environment.reset(seed=0)
    if trace:
        tracemalloc.start(8)
        snapshot = tracemalloc.take_snapshot()
    counts, last_mb = object_counts(), resident_mb()
    print(f"{episodes:,} episodes of {source} ({len(environment.configs)} instances), "
          f"{condition}, text {'on' if text else 'off'}; start RSS {last_mb:,.0f} MB, "
          f"{sum(counts.values()):,} objects", flush=True)
    started, steps = time.perf_counter(), 0
    for played in range(1, episodes + 1):
        while environment.agents:
            observations, *_ = environment.step(random_actions(observations, rng))
            steps += 1
        observations, _ = environment.reset()
        elapsed = time.perf_counter() - started
        out_of_time = minutes is not None and elapsed > 60 * minutes
        if played % every == 0 or out_of_time:
            now_counts, mb = object_counts(), resident_mb()
            print(f"{played:7,} episodes  RSS {mb:7,.0f} MB ({mb - last_mb:+6,.0f})  "
                  f"{sum(now_counts.values()):,} objects  {played / elapsed:5.1f} episodes/s "
                  f"({steps:,} steps, {elapsed:,.0f} s)  grew: "
                  f"{grown(now_counts, counts, 6)}", flush=True)
            if trace:
                now = tracemalloc.take_snapshot()
                for stat in now.compare_to(snapshot, "lineno")[:6]:
                    print(f"      {stat}", flush=True)
                snapshot = now
            counts, last_mb = now_counts, mb
        if out_of_time:
            print(f"stopped after {minutes:g} minutes ({played:,} of {episodes:,} episodes)")
            break
    environment.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=10_000)
    parser.add_argument("--every", type=int, default=1000,
                        help="print the resident memory every this many episodes")
    parser.add_argument("--source", default="cocobench-full")
    parser.add_argument("--condition", default="C0_blind")
    parser.add_argument("--no-text", action="store_true", help="play with text=False")
    parser.add_argument("--minutes", type=float,
                        help="stop after this many minutes (a line is printed then)")
    parser.add_argument("--tracemalloc", action="store_true",
                        help="also print the source lines whose allocations grew most")
    args = parser.parse_args()
    if args.episodes < 1 or args.every < 1:
        parser.error("--episodes and --every must be positive")
    play(args.source, args.condition, not args.no_text, args.episodes, args.every,
         args.minutes, args.tracemalloc)


if __name__ == "__main__":
    main()
