"""Ray executor throughput against the 200 ms fake model server of bench/harness.py.

The same batch (N episodes at --jobs J, every call answered after 200 ms by a server in its
own process) runs with the local executor and with 1, 2 and 4 Ray workers on a private local
Ray started once (its start is printed apart). Each line gives the wall time and its ratio
to the ideal (total model time / J), the Ray workers' start-up (a new process importing the
planner stack, each run) included. Prints medians over --repeats runs.

(Named ray_scaling.py, not ray.py: a script's own folder comes first on sys.path, and a
bench/ray.py would shadow the ray package.)

Usage: python bench/ray_scaling.py [--episodes 64] [--jobs 32] [--max-steps 20]
       [--workers 1 --workers 2 --workers 4] [--repeats 3] [--transport http|litellm]
"""

from __future__ import annotations

import argparse
import asyncio
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from harness import SERVER  # bench/harness.py: the fake OpenAI-compatible server

from benchmark_adapter.tasks import load_tasks
from cocobench_agents.harness import (
    Condition,
    RunFolder,
    RunOptions,
    execute_and_close,
    plan_episodes,
)
from cocobench_agents.harness.ray_executor import RayOptions, execute_on_ray
from cocobench_agents.harness.ray_session import ray_session
from cocobench_agents.models import ModelPool, ModelSettings


def one_run(planned, settings: ModelSettings, jobs: int, workers: int | None
            ) -> tuple[float, int]:
    """(wall s, model calls) of one batch; workers None = the local executor."""
    with tempfile.TemporaryDirectory() as tmp:
        folder = RunFolder(Path(tmp) / "run")
        folder.create({"name": "bench"})
        start = time.perf_counter()
        if workers is None:
            asyncio.run(execute_and_close(planned, folder, ModelPool(settings), jobs=jobs))
        else:
            execute_on_ray(planned, folder, settings, jobs=jobs,
                           options=RayOptions(workers=workers))
        wall = time.perf_counter() - start
        records = list(folder.results())
    errors = sum(bool(r.get("infra_error")) for r in records)
    if errors or len(records) != len(planned):
        raise SystemExit(f"{errors} episodes failed, {len(records)}/{len(planned)} recorded")
    return wall, sum(r["usage"]["model_calls"] for r in records)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=64)
    parser.add_argument("--jobs", type=int, default=32)
    parser.add_argument("--max-steps", type=int, default=20)
    parser.add_argument("--delay", type=float, default=0.2)
    parser.add_argument("--workers", type=int, action="append")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--transport", default="http", choices=["http", "litellm"])
    args = parser.parse_args()
    worker_counts = args.workers or [1, 2, 4]
    server = subprocess.Popen([sys.executable, "-c", SERVER, str(args.delay)],
                              stdout=subprocess.PIPE, text=True)
    try:
        url = server.stdout.readline().strip()
        planned = plan_episodes(load_tasks("cocobench-240")[:args.episodes], ["openai/bench"],
                                [Condition("centralized", "blind")], 1,
                                RunOptions(max_steps=args.max_steps))
        settings = ModelSettings(api_base=url, max_concurrency=args.jobs, timeout_s=30,
                                 transport=args.transport)
        ModelPool(settings).validate("openai/bench")
        print(f"{len(planned)} episodes, --jobs {args.jobs}, calls of {args.delay * 1e3:.0f} ms"
              f" (--transport {args.transport}), median of {args.repeats}:")
        report("local executor", [one_run(planned, settings, args.jobs, None)
                                  for _ in range(args.repeats)], args)
        started = time.perf_counter()
        with ray_session(None, local_cpus=max(worker_counts)):
            print(f"  (local Ray started in {time.perf_counter() - started:.1f} s, "
                  f"{max(worker_counts)} logical CPUs)")
            for workers in worker_counts:
                report(f"Ray, {workers} worker{'s' if workers > 1 else ''}",
                       [one_run(planned, settings, args.jobs, workers)
                        for _ in range(args.repeats)], args)
    finally:
        server.kill()


def report(label: str, runs: list[tuple[float, int]], args) -> None:
    wall = statistics.median(r[0] for r in runs)
    calls = runs[0][1]
    ideal = calls * args.delay / args.jobs
    print(f"  {label:18s} {wall:6.1f} s = {wall / ideal:4.2f}x ideal ({ideal:.1f} s for "
          f"{calls} calls; load average {os.getloadavg()[0]:.1f})")


if __name__ == "__main__":
    main()
