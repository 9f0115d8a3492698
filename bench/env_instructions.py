"""Instructions per environment step, counted by valgrind: a measure of a change to the
environment's code that a shared machine's swings do not move (here, the speed of the same
run swings by a third from minute to minute, more than most single changes give).

Plays random legal moves (from each seat's mask, `bench/env.py`'s) on the 36 shared configs,
text off, under cachegrind (no cache simulation) with `PYTHONHASHSEED=0`: once for
`--warm` steps then `--steps` more, once for the warm-up alone, and prints the difference
per step. Run it on two versions of the tree (e.g. with the other on PYTHONPATH) to compare.
The same count repeats within about 1 % (three D1_image counts: 9.64, 9.67 and 9.76
million). Instructions are not time: valgrind counts every byte a `rep movs` or `memset`
copies, so a change to how pixels are copied shows larger here than in time, and cache
misses not at all.

Usage: python bench/env_instructions.py [--steps N] [--warm N] [--condition C]…
(needs valgrind on the PATH and the env extra: pip install -e '.[env]'; a condition takes
about a minute)
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

BENCH = Path(__file__).resolve().parent
DEFAULT_CONDITIONS = ("C0_blind", "D1_blind", "C0_image", "D1_image")
#: The play counted: `warm` steps, then `steps` more (seeds 0 and 1, as bench/env.py's).
PLAY = """
import sys
sys.path.insert(0, {bench!r})
import env
from cocobench_agents.envs import parallel_env
environment = parallel_env(str(env.SHARED), condition={condition!r}, text=False)
env.run(environment, {warm}, 0)
if {steps}:
    env.run(environment, {steps}, 1)
"""


def instructions(condition: str, warm: int, steps: int) -> int:
    """The instructions a process executes playing `warm` then `steps` steps."""
    code = PLAY.format(bench=str(BENCH), condition=condition, warm=warm, steps=steps)
    done = subprocess.run(
        ["valgrind", "--tool=cachegrind", "--cache-sim=no", "--cachegrind-out-file=/dev/null",
         sys.executable, "-c", code],
        capture_output=True, text=True, env={**os.environ, "PYTHONHASHSEED": "0"}, check=False)
    counted = re.search(r"I\s+refs:\s+([\d,]+)", done.stderr)
    if done.returncode != 0 or counted is None:
        sys.exit(f"{condition}: the counted play failed (exit {done.returncode}):\n"
                 f"{done.stderr[-2000:]}")
    return int(counted.group(1).replace(",", ""))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=300)
    parser.add_argument("--warm", type=int, default=200)
    parser.add_argument("--condition", action="append",
                        help=f"conditions to count (default: {', '.join(DEFAULT_CONDITIONS)})")
    args = parser.parse_args()
    if args.steps < 1 or args.warm < 0:
        parser.error("--steps must be at least 1 and --warm at least 0")
    if shutil.which("valgrind") is None:
        sys.exit("valgrind is not on the PATH (apt install valgrind)")
    print(f"instructions per env step: {args.steps} random steps after {args.warm}, text off "
          "(cachegrind, PYTHONHASHSEED=0)")
    for condition in args.condition or DEFAULT_CONDITIONS:
        with ThreadPoolExecutor(2) as both:  # the two counted processes at once
            counts = [both.submit(instructions, condition, args.warm, steps)
                      for steps in (args.steps, 0)]
        played, warm = (count.result() for count in counts)
        print(f"  {condition:9s} {(played - warm) / args.steps / 1e6:6.2f} million", flush=True)


if __name__ == "__main__":
    main()
