"""Learnability, shown: a linear softmax policy over features of each menu entry, trained with
REINFORCE on the C0 environment of `cocobench-240`'s first 160 instances, against the `random`
model's choice (uniform over the menu) on the 80 held out.

A menu entry's features: its verb (find, pick up, put, slice, …: one-hot) and the same verb
when the entry's object is named in the GOAL. No LLM; a few minutes on one core.

Usage: python examples/learned-seat/train.py [--minutes 3] [--plot docs/img/env-learning-curve.png]
(needs the env extra: pip install -e '.[env]')
"""

from __future__ import annotations

import argparse
import re
import time

import numpy as np

from cocobench_agents.envs import parallel_env

VERBS = ("find", "explore", "wait", "pick up", "put", "open", "close", "drop", "slice",
         "toggle", "clean", "fill", "empty", "push", "pull")
MENU_LINE = re.compile(r"^\s*(\d+): (?:agent_\d+: )?(.*?)(?: \[agent_\d+\])?$")
SEAT = "team"


def goal_words(prompt: str) -> set[str]:
    """The object names the GOAL section mentions."""
    goal = prompt.split("GOAL:", 1)[-1].split("GOAL PROGRESS", 1)[0]
    return set(re.findall(r"[A-Z][A-Za-z]+", goal))


def features(observation: dict) -> tuple[np.ndarray, np.ndarray]:
    """Each legal entry's feature row, and its menu id (DONE is never offered: the baseline
    `random` never chooses it either)."""
    goal = goal_words(observation["prompt"])
    rows, ids = [], []
    for line in observation["menu"].splitlines():
        match = MENU_LINE.match(line)
        if not match:
            continue
        name = match.group(2)
        verb = next((i for i, v in enumerate(VERBS) if name.startswith(v)), len(VERBS))
        row = np.zeros(2 * (len(VERBS) + 1))
        row[verb] = 1
        if any(word in goal for word in re.findall(r"[A-Z][A-Za-z]+", name)):
            row[len(VERBS) + 1 + verb] = 1
        rows.append(row)
        ids.append(int(match.group(1)))
    return np.array(rows), np.array(ids)


def play(environment, task_id: str, choose) -> tuple[float, list]:
    """One episode; its return and the (features, choice, reward) of each step."""
    observations, _ = environment.reset(options={"task_id": task_id})
    total, steps = 0.0, []
    while environment.agents:
        rows, ids = features(observations[SEAT])
        index = choose(rows)
        observations, rewards, *_ = environment.step({SEAT: int(ids[index])})
        total += rewards[SEAT]
        steps.append((rows, index, rewards[SEAT]))
    return total, steps


def softmax(rows: np.ndarray, weights: np.ndarray) -> np.ndarray:
    logits = rows @ weights
    logits -= logits.max()
    p = np.exp(logits)
    return p / p.sum()


def evaluate(environment, tasks: list[str], choose) -> float:
    return float(np.mean([play(environment, t, choose)[0] for t in tasks]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=3.0)
    parser.add_argument("--plot", default=None, help="write the learning curve here (PNG)")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    environment = parallel_env("cocobench-240", condition="C0_blind")
    tasks = [c.task_id for c in environment.configs]
    train, held_out = tasks[:160], tasks[160:]
    rng = np.random.default_rng(args.seed)
    weights = np.zeros(2 * (len(VERBS) + 1))

    def sample(rows):
        return int(rng.choice(len(rows), p=softmax(rows, weights)))

    def uniform(rows):
        return int(rng.integers(len(rows)))

    random_score = evaluate(environment, held_out, uniform)
    print(f"random on the {len(held_out)} held-out instances: mean return {random_score:.3f}")
    curve = [(0, 0.0, evaluate(environment, held_out, sample))]
    baseline, episodes, started = 0.0, 0, time.perf_counter()
    deadline = started + 60 * args.minutes
    while time.perf_counter() < deadline:
        for _ in range(100):
            total, steps = play(environment, train[int(rng.integers(len(train)))], sample)
            episodes += 1
            baseline += 0.05 * (total - baseline)
            to_go = total
            for rows, index, reward in steps:  # REINFORCE: ∇ log π(a) × (G_t − b)
                p = softmax(rows, weights)
                weights += 0.02 * (to_go - baseline) * (rows[index] - p @ rows)
                to_go -= reward
        score = evaluate(environment, held_out, sample)
        curve.append((episodes, time.perf_counter() - started, score))
        print(f"{episodes:6} episodes  {curve[-1][1]:6.0f} s  held-out mean return {score:.3f}")
    print(f"learned: {curve[-1][2]:.3f} vs random {random_score:.3f} on held-out instances")
    if args.plot:
        plot(curve, random_score, args.plot)


def plot(curve: list, random_score: float, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(figsize=(6, 3.5))
    axes.plot([c[0] for c in curve], [c[2] for c in curve], marker="o", label="linear policy")
    axes.axhline(random_score, color="grey", linestyle="--", label="random")
    axes.set_xlabel("training episodes (C0_blind, cocobench-240, 160 instances)")
    axes.set_ylabel("mean return, 80 held-out")
    axes.legend()
    figure.tight_layout()
    figure.savefig(path, dpi=120)


if __name__ == "__main__":
    main()
