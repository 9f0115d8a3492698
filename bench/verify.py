"""How long `cocobench verify` takes over a whole run.

Makes (or takes, with --run) a `cocobench run --suite cocobench-full --model greedy
--baselines` run folder (2,691 episodes), then replays every episode of it through the
embedded simulator (`cocobench_agents.verify.verify_run`) and prints the wall time, the
episodes a second, the processes used, the machine's load average and the CPU time used
(the wall time is shared with whatever else runs; the CPU time is not). With --shared DIR it
also makes a scripted run over the task configs of DIR (the 36 official ones) under all six
conditions and verifies it, those configs being the reference. Aim (issue 40):
cocobench-full in under 60 s on 2 cores.

Usage: python bench/verify.py [--run RUN] [--suite cocobench-full] [--jobs N]
       [--repeats 1] [--shared ../shared/cocobench-data/tasks]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from cocobench_agents.harness.workers import available_cores
from cocobench_agents.verify import reference_configs, verify_run

#: The scripted model's replies: an action, a wait, a reply no parser reads, an id on no
#: menu, and DONE at the end of the script (each decision kind the verifier checks).
SCRIPT = ["REASON: start\nACTION: 0", "ACTION: 3", "ACTION: 13", "I would rather not",
          "ACTION: 99999", "ACTION: 4", "ACTION: 1", "ACTION: 14", "ACTION: 2", "ACTION: DONE"]


def make_run(out: Path, args: list[str], cores: int) -> float:
    command = [sys.executable, "-m", "cocobench_agents.cli", "run", *args,
               "--workers", str(cores), "--jobs", str(2 * cores), "--out", str(out)]
    started = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True,
                          env={**os.environ, "NO_COLOR": "1"})
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(command)} failed ({done.returncode}):\n{done.stderr}")
    return time.perf_counter() - started


def timed_verify(run: Path, jobs: int, repeats: int, reference: dict | None = None) -> None:
    times, outcome = [], None
    load_before = os.getloadavg()
    cpu_before = os.times()
    for _ in range(repeats):
        outcome = verify_run(run, jobs=jobs, reference=reference)
        times.append(outcome.elapsed_s)
    load_after = os.getloadavg()
    cpu = [after - before for after, before in zip(os.times(), cpu_before)]
    cpu_s = sum(cpu[:4]) / repeats  # user + system, of this process and its workers
    assert outcome is not None
    episodes = len(outcome.verdicts)
    median = statistics.median(times)
    print(f"{run}: {episodes} episodes, {dict(outcome.counts)}, "
          f"{'all verified' if outcome.ok else 'NOT all verified'}")
    print(f"  verify: {median:.1f} s (median of {repeats}), {episodes / median:.0f} "
          f"episodes/s, {outcome.processes} processes; load average before "
          f"{load_before[0]:.1f}, after {load_after[0]:.1f} (1 min)")
    print(f"  CPU time: {cpu_s:.1f} s (user + system, all processes): on {jobs} idle cores "
          f"about {cpu_s / jobs:.1f} s")
    for key, verdict in outcome.verdicts:
        if verdict.status != "verified":
            print(f"  {key.name()}: {verdict.describe()}")
            break


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--run", type=Path, help="verify this run folder (default: make one)")
    parser.add_argument("--suite", default="cocobench-full")
    parser.add_argument("--jobs", type=int, default=None, help="processes (default: cores)")
    parser.add_argument("--repeats", type=int, default=1)
    parser.add_argument("--shared", type=Path, help="also a scripted run over these configs "
                        "under all six conditions")
    args = parser.parse_args()
    cores = available_cores()
    jobs = args.jobs or cores
    print(f"{cores} cores, {jobs} verify processes; load average {os.getloadavg()[0]:.1f}")
    with tempfile.TemporaryDirectory() as tmp:
        run = args.run
        if run is None:
            run = Path(tmp) / "full"
            took = make_run(run, ["--suite", args.suite, "--model", "greedy", "--baselines"],
                            cores)
            print(f"run: {args.suite} greedy + baselines in {took:.1f} s")
        timed_verify(run, jobs, args.repeats)
        if args.shared:
            script = Path(tmp) / "script.json"
            script.write_text(json.dumps(SCRIPT))
            shared = Path(tmp) / "shared"
            took = make_run(shared, ["--task", str(args.shared), "--model",
                                     f"scripted:{script}", "--conditions", "all"], cores)
            print(f"run: scripted over {args.shared} × all conditions in {took:.1f} s")
            timed_verify(shared, jobs, args.repeats, reference_configs([args.shared]))


if __name__ == "__main__":
    main()
