"""`cocobench report` on repeated epochs: the cost of clustered intervals, reliability and
model comparisons.

Writes two synthetic run folders with the same number of episodes (result lines copied from
the report tests' fixture): --instances instances × --epochs epochs, and the same count as
one epoch of --instances × --epochs instances, for --models models under 2 conditions. Times
`compute_tables` (the tables, no files) --repeats times on each and prints the medians and
their ratio: what repeated epochs (clustered intervals, the reliability table) add.

Usage: python bench/report_epochs.py [--instances 240] [--epochs 5] [--models 3] [--repeats 3]
"""

from __future__ import annotations

import argparse
import random
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from cocobench_agents.reports import compute_tables, load_runs
from tests.report.helpers import TEMPLATE, write_run

CONDITIONS = ("C0_image", "C0_blind")


def run_folder(path: Path, models: int, instances: int, epochs: int) -> Path:
    rng = random.Random(0)
    lines = []
    for m in range(models):
        for condition in CONDITIONS:
            for task in range(instances):
                p = rng.betavariate(0.3, 0.4)  # clustered: most instances always or never
                for epoch in range(epochs):
                    ok = rng.random() < p
                    lines.append({**TEMPLATE, "model": f"model-{m}", "condition": condition,
                                  "task_id": f"T{task:04d}", "epoch": epoch,
                                  "task_success": int(ok), "legal_plan": float(ok),
                                  "construct_score": rng.random(),
                                  "elapsed_s": rng.uniform(1, 100)})
    return write_run(path, lines)


def median_seconds(run: Path, repeats: int) -> float:
    data = load_runs([run])
    times = []
    for _ in range(repeats):
        start = time.process_time()
        compute_tables(data)
        times.append(time.process_time() - start)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--instances", type=int, default=240)
    parser.add_argument("--epochs", type=int, default=5)
    parser.add_argument("--models", type=int, default=3)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        repeated = run_folder(Path(tmp) / "epochs", args.models, args.instances, args.epochs)
        single = run_folder(Path(tmp) / "one", args.models, args.instances * args.epochs, 1)
        clustered = median_seconds(repeated, args.repeats)
        flat = median_seconds(single, args.repeats)
    episodes = args.models * len(CONDITIONS) * args.instances * args.epochs
    print(f"{episodes:,} episodes, {args.models} models: {args.instances} instances x "
          f"{args.epochs} epochs {clustered:.2f} s CPU; {args.instances * args.epochs} "
          f"instances x 1 epoch {flat:.2f} s CPU; ratio {clustered / flat:.2f}")


if __name__ == "__main__":
    main()
