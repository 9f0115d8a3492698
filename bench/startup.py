"""Start-up: how long `cocobench` takes to answer what needs no model stack.

Prints the median wall time (fresh interpreter each run) of `--help`, `run --help`, the
usual user mistakes (missing API key, unknown model, bad option) and resuming a finished
run, and whether LangGraph or LiteLLM was imported (it must not be). Aim: well under 1 s
each, against ~2 s (help) and ~6 s (missing key) before the CLI stopped importing them.

Usage: python bench/startup.py [--repeats 7]
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

PROBE = ("import sys\nfrom cocobench_agents.cli import main\ncode = main(sys.argv[1:])\n"
         "heavy = [m for m in ('langgraph', 'litellm') if m in sys.modules]\n"
         "print('HEAVY', *heavy, file=sys.stderr)\n")


def timed(argv: list[str], env: dict[str, str]) -> tuple[float, list[str]]:
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", PROBE, *argv], capture_output=True,
                          text=True, env=env, timeout=120)
    wall = time.perf_counter() - start
    heavy = next(line for line in done.stderr.splitlines() if line.startswith("HEAVY"))
    return wall, heavy.split()[1:]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    env = {k: v for k, v in os.environ.items() if not k.endswith("_API_KEY")}
    with tempfile.TemporaryDirectory() as tmp:
        finished = Path(tmp) / "finished"
        subprocess.run([sys.executable, "-m", "cocobench_agents.cli", "run", "--model",
                        "greedy", "--suite", "demo", "--out", str(finished)],
                       check=True, capture_output=True, env=env)
        cases = {
            "cocobench --help": ["--help"],
            "cocobench run --help": ["run", "--help"],
            "missing API key": ["run", "--model", "openai/gpt-4o", "--out", f"{tmp}/a"],
            "unknown model": ["run", "--model", "gpt4o-typo", "--out", f"{tmp}/b"],
            "bad option": ["run", "--model", "greedy", "--jobs", "x", "--out", f"{tmp}/c"],
            "resume a finished run": ["run", "--out", str(finished), "--resume"],
        }
        for name, argv in cases.items():
            runs = [timed(argv, env) for _ in range(args.repeats)]
            heavy = sorted({m for _, mods in runs for m in mods}) or ["none"]
            print(f"{name:24s} median {statistics.median(w for w, _ in runs):5.2f} s "
                  f"(min {min(w for w, _ in runs):.2f}; heavy imports: {', '.join(heavy)})")


if __name__ == "__main__":
    main()
