"""Embedded simulator throughput and the time to validate the shared configs.

Prints medians over repeated runs:
- skill steps per second through `SkillExecutor` alone (the simulator + skill layer),
- skill steps per second through a full `Episode` (menu, goals and recording included),
- seconds to validate the 36 shared configs (oracle + metrics + gates), single process.

Usage: python bench/sim.py [--repeats N] [--tasks PATH]
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

from benchmark_adapter.oracles import oracle_plan, run_oracle
from benchmark_adapter.scene_setup import apply_init_actions
from benchmark_adapter.sim.embedded import EmbeddedController
from benchmark_adapter.skills import SkillExecutor
from benchmark_adapter.tasks import load_tasks
from benchmark_adapter.validation import validate_task

SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "cocobench-data" / "tasks"


def oracle_calls(config) -> list[str]:
    """The skill calls an oracle issues (its plans are open-loop)."""
    return [item["label"] for item in run_oracle(config)["trajectory"] if "skill_result" in item]


def executor_rate(workload) -> float:
    """Skill steps per second through the executor alone."""
    steps, elapsed = 0, 0.0
    for config, calls in workload:
        controller = EmbeddedController(config)
        controller.reset()
        apply_init_actions(controller, config.init_state.init_actions)
        executor = SkillExecutor(controller)
        start = time.perf_counter()
        for call in calls:
            executor.execute(call)
        elapsed += time.perf_counter() - start
        steps += len(calls)
    return steps / elapsed


def episode_rate(configs) -> float:
    """Skill steps per second through a recorded Episode (oracle plans)."""
    start = time.perf_counter()
    steps = sum(sum(1 for i in run_oracle(c)["trajectory"] if "skill_result" in i)
                for c in configs)
    return steps / (time.perf_counter() - start)


def validate_seconds(configs) -> float:
    start = time.perf_counter()
    rows = [validate_task(c) for c in configs]
    elapsed = time.perf_counter() - start
    assert all(r.passed for r in rows), [r.reason for r in rows if not r.passed]
    return elapsed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--tasks", default=str(SHARED) if SHARED.exists() else "demo")
    args = parser.parse_args()
    configs = load_tasks(args.tasks)
    for c in configs:
        oracle_plan(c)  # fail early on a cell without an oracle
    workload = [(c, oracle_calls(c)) for c in configs]
    n_steps = sum(len(calls) for _, calls in workload)
    print(f"workload: {len(configs)} configs from {args.tasks}, {n_steps} oracle skill steps, "
          f"median of {args.repeats} runs")
    rates = [executor_rate(workload) for _ in range(args.repeats)]
    print(f"executor skill steps/s:   {statistics.median(rates):10,.0f}  (aim > 5,000)")
    rates = [episode_rate(configs) for _ in range(args.repeats)]
    print(f"episode skill steps/s:    {statistics.median(rates):10,.0f}")
    times = [validate_seconds(configs) for _ in range(args.repeats)]
    print(f"validate {len(configs)} configs:      {statistics.median(times):10.3f} s  (aim < 1 s)")


if __name__ == "__main__":
    main()
