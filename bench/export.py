"""`cocobench export` throughput: decisions written per second from a real run folder.

Makes a real run with `cocobench run` (greedy and random, C0_blind and D1_blind, the first
--instances instances of cocobench-240), then exports it --repeats times into fresh folders
in this process, printing the median wall time, decisions per second and the sizes of the
run folder and the dataset. Needs the export extra (pyarrow).

Usage: python bench/export.py [--instances 60] [--repeats 3]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from cocobench_agents.cli import main
from cocobench_agents.export import export_runs


def size_mb(folder: Path) -> float:
    return sum(p.stat().st_size for p in folder.rglob("*") if p.is_file()) / 1e6


def main_bench() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--instances", type=int, default=60)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        run = Path(tmp) / "run"
        assert main(["run", "--suite", "cocobench-240", "--limit", str(args.instances),
                     "--model", "greedy", "--model", "random", "--conditions",
                     "C0_blind,D1_blind", "--out", str(run)]) == 0
        times, summary = [], None
        for n in range(args.repeats):
            start = time.perf_counter()
            summary = export_runs([run], Path(tmp) / f"ds{n}")
            times.append(time.perf_counter() - start)
        assert summary is not None
        median = statistics.median(times)
        print(f"run folder: {summary.episodes} episodes, {size_mb(run):.1f} MB")
        print(f"export: {summary.rows} decisions in {median:.2f} s (median of {args.repeats}),"
              f" {summary.rows / median:,.0f} decisions/s; dataset "
              f"{size_mb(Path(tmp) / 'ds0'):.1f} MB")


if __name__ == "__main__":
    main_bench()
