"""How local runs scale with worker processes.

Runs `cocobench run --suite SUITE --model greedy --baselines --workers W --jobs 2W` (built-in
models only: the run is CPU-bound, the case worker processes exist for) for W = 1, 2, 4, … up
to this machine's cores, and prints the median wall time of each (the whole command, as a user
waits for it), its speed-up over one worker and that speed-up as a share of linear. Aim
(issue 24): `cocobench-full` at >= 12x on 16 cores (75 % of linear), >= 1.8x on 2 cores.

Usage: python bench/scaling.py [--suite cocobench-240]… [--repeats 3] [--workers 1 2 4]…
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from cocobench_agents.harness.workers import available_cores


def worker_counts(cores: int) -> list[int]:
    """1, 2, 4, … up to `cores`, and `cores` itself."""
    counts, count = [], 1
    while count < cores:
        counts.append(count)
        count *= 2
    return [*counts, cores]


def wall_time(suite: str, workers: int) -> float:
    """Seconds one whole run takes, in a fresh run folder."""
    with tempfile.TemporaryDirectory() as tmp:
        command = [sys.executable, "-m", "cocobench_agents.cli", "run", "--suite", suite,
                   "--model", "greedy", "--baselines", "--workers", str(workers),
                   "--jobs", str(2 * workers), "--out", str(Path(tmp) / "run")]
        started = time.perf_counter()
        done = subprocess.run(command, capture_output=True, text=True,
                              env={**os.environ, "NO_COLOR": "1"})
        elapsed = time.perf_counter() - started
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(command)} failed ({done.returncode}):\n{done.stderr}")
    return elapsed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--suite", action="append", dest="suites",
                        help="suite to run (repeatable; default: cocobench-240 and "
                             "cocobench-full)")
    parser.add_argument("--repeats", type=int, default=3, help="runs per point (median)")
    parser.add_argument("--workers", type=int, nargs="+",
                        help="worker counts (default: 1, 2, 4, … up to the cores)")
    args = parser.parse_args()
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
