"""The embedded simulator's invariant sweep (issue 41): random menu, off-menu and native steps
on every instance of cocobench-full and every shared config, several seeds each, with every
invariant of `benchmark_adapter.invariants` checked after each step and each
episode replayed byte for byte. Prints the figures and every breach; exits 1 on a breach.

Usage: python bench/sim_sweep.py [--seeds N] [--first-seed N] [--steps N] [--processes N]
                                [--limit N]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from benchmark_adapter.invariants import InvariantBroken, play
from benchmark_adapter.tasks import TaskConfig, load_task, load_tasks

SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "cocobench-data" / "tasks"


def instances(limit: int | None) -> list[TaskConfig]:
    """All of cocobench-full, then the shared configs (those not in it)."""
    configs = load_tasks("cocobench-full")
    seen = {c.task_id for c in configs}
    if SHARED.is_dir():
        configs += [c for c in map(load_task, sorted(SHARED.glob("*.json")))
                    if c.task_id not in seen]
    return configs[:limit] if limit else configs


def sweep_one(job: tuple[TaskConfig, int, int]) -> dict:
    """One instance × seed: its counts, its time, and its breach (or None)."""
    config, seed, steps = job
    start = time.perf_counter()
    try:
        played = play(config, seed, steps)
    except InvariantBroken as exc:
        return {"task": config.task_id, "seed": seed, "breach": str(exc)}
    except Exception as exc:  # noqa: BLE001 - a breach too: one episode never ends the sweep
        return {"task": config.task_id, "seed": seed,
                "breach": f"{config.task_id} seed {seed}: play raised {exc!r}"}
    return {"task": config.task_id, "seed": seed, "breach": None, "kinds": played.kinds,
            "refused": played.refused, "seconds": time.perf_counter() - start}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--steps", type=int, default=200)
    parser.add_argument("--processes", type=int, default=1)
    parser.add_argument("--limit", type=int, default=None, help="only the first N instances")
    args = parser.parse_args()
    configs = instances(args.limit)
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    jobs = [(c, seed, args.steps) for c in configs for seed in seeds]
    start = time.perf_counter()
    if args.processes > 1:
        with ProcessPoolExecutor(args.processes) as pool:
            rows = list(pool.map(sweep_one, jobs, chunksize=8))
    else:
        rows = [sweep_one(job) for job in jobs]
    wall = time.perf_counter() - start
    breaches = [r for r in rows if r["breach"]]
    clean = [r for r in rows if not r["breach"]]
    kinds: dict[str, int] = {}
    for row in clean:
        for kind, count in row["kinds"].items():
            kinds[kind] = kinds.get(kind, 0) + count
    steps = sum(kinds.values())
    print(f"instances {len(configs)} × seeds {seeds.start}-{seeds.stop - 1} = episodes "
          f"{len(rows)}, "
          f"{args.steps} steps each")
    print(f"steps {steps:,} (menu {kinds.get('menu', 0):,}, off-menu skill "
          f"{kinds.get('skill', 0):,}, native {kinds.get('native', 0):,}); refused native "
          f"{sum(r['refused'] for r in clean):,}, each leaving the world unchanged")
    if clean:
        per_step = statistics.median(r["seconds"] / args.steps for r in clean)
        print(f"median {per_step * 1000:.2f} ms a step (checks and replay included); "
              f"wall {wall:.0f} s over {args.processes} process(es)")
    print(f"breaches {len(breaches)}")
    for row in breaches:
        print(f"  {row['breach']}")
    return 1 if breaches else 0


if __name__ == "__main__":
    sys.exit(main())
