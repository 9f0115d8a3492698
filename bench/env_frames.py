"""The frames' share of an image-condition environment step: milliseconds per step spent
making the robots' camera pixels, apart from the rest of the step.

Plays random legal moves (from each seat's mask) on the 36 shared configs under C0_image and
D1_image (text off: the frames, not the prompt, are measured) and times, in CPU time, every
`Episode.frame_pixels` call (the embedded simulator's view, its picture drawn or the kept
one, its pixels written into the observation's array) and within it the pictures drawn
(`render._draw_view`). Prints, per condition, the median over the runs of: env steps per
CPU-second, the frames' ms per step (and the pictures drawn per step, and their ms), and the
rest of the step's ms. The rate an image condition can reach is 1,000 / (rest + frames)
steps per CPU-second: compare the frames' ms with the 2 ms a step has at the aim of 500 env
steps/s.

Usage: python bench/env_frames.py [--steps N] [--repeats N] [--condition C]…
(needs the env extra: pip install -e '.[env]')
"""

from __future__ import annotations

import argparse
import collections
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from env import random_actions  # (the bench folder is no package: on the path above)

from benchmark_adapter.episode import Episode
from benchmark_adapter.sim.embedded import render
from cocobench_agents.envs import parallel_env

SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "cocobench-data" / "tasks"
spent: collections.Counter = collections.Counter()
calls: collections.Counter = collections.Counter()


def timed(owner, name: str) -> None:
    """Wrap `owner.name` to add its CPU time and calls to `spent` and `calls`."""
    function = getattr(owner, name)

    def wrapper(*args, **kwargs):
        started = time.process_time()
        try:
            return function(*args, **kwargs)
        finally:
            spent[name] += time.process_time() - started
            calls[name] += 1
    setattr(owner, name, wrapper)


def run(environment, steps: int, rng: np.random.Generator, observations):
    for _ in range(steps):
        if not environment.agents:
            observations, _ = environment.reset()
        observations, *_ = environment.step(random_actions(observations, rng))
    return observations


def measure(source: str, condition: str, steps: int, repeats: int) -> dict[str, float]:
    environment = parallel_env(source, condition=condition, text=False)
    rng = np.random.default_rng(0)
    observations = run(environment, 200, rng, environment.reset(seed=0)[0])  # warm
    figures = collections.defaultdict(list)
    for _ in range(repeats):
        spent.clear()
        calls.clear()
        started = time.process_time()
        observations = run(environment, steps, rng, observations)
        cpu = time.process_time() - started
        figures["rate"].append(steps / cpu)
        figures["frames"].append(1000 * spent["frame_pixels"] / steps)
        figures["drawn"].append(calls["_draw_view"] / steps)
        figures["drawing"].append(1000 * spent["_draw_view"] / steps)
        figures["rest"].append(1000 * (cpu - spent["frame_pixels"]) / steps)
    environment.close()
    return {key: statistics.median(values) for key, values in figures.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=1000)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--source", default=str(SHARED))
    parser.add_argument("--condition", action="append",
                        help="conditions to measure (default: C0_image, D1_image)")
    args = parser.parse_args()
    timed(Episode, "frame_pixels")
    timed(render, "_draw_view")
    print(f"{args.steps} steps per run, median of {args.repeats} runs, CPU time, source "
          f"{args.source}")
    for condition in args.condition or ("C0_image", "D1_image"):
        f = measure(args.source, condition, args.steps, args.repeats)
        print(f"{condition:9} {f['rate']:6,.0f} env steps per CPU-s  frames {f['frames']:5.2f} "
              f"ms/step ({f['drawn']:.2f} pictures drawn: {f['drawing']:5.2f} ms)  rest "
              f"{f['rest']:5.2f} ms/step  (load {os.getloadavg()[0]:.1f})", flush=True)


if __name__ == "__main__":
    main()
