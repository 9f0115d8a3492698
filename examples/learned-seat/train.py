"""Learnability, shown: a linear softmax policy over features of each menu entry, trained with
REINFORCE and the environment's default rewards on the C0 environment of `cocobench-240`'s
first 160 instances, and measured on the 80 held out (return, goal progress, success rate)
against three baselines: doing nothing (DONE at once), `random` (uniform over the menu, never
DONE) and the oracle (the instance's reference plan).

A menu entry's features: its verb (find, pick up, put, slice, …: one-hot), the same verb when
the entry's object is named in the GOAL, and again when an unmet goal check names it (and its
robot, where the check names one). No LLM; a few minutes on one core.

Usage: python examples/learned-seat/train.py [--episodes 800] [--every 100] [--seed 0]
       [--rate 0.05] [--held-out 80] [--plot docs/img/env-learning-curve.png]
(needs the env extra: pip install -e '.[env]')
"""

from __future__ import annotations

import argparse
import re
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from cocobench_agents.envs import DONE, parallel_env
from cocobench_agents.envs.oracle_partner import OraclePlan

VERBS = ("find", "explore", "wait", "pick up", "put", "open", "close", "drop", "slice",
         "toggle", "clean", "fill", "empty", "push", "pull")
MENU_LINE = re.compile(r"^\s*(\d+): (?:(agent_\d+): )?(.*?)(?: \[agent_\d+\])?$")
NAME = re.compile(r"[A-Z][A-Za-z]+")
AGENT = re.compile(r"agent_\d+")
SEAT = "team"
#: Feature blocks, each one-hot over the verbs (and "other"): every entry; an entry whose object
#: the GOAL names; an entry whose object (and robot, where the check names one) an unmet check
#: of GOAL PROGRESS names.
BLOCKS = 3


def goal_words(prompt: str) -> set[str]:
    """The object names the GOAL section mentions."""
    goal = prompt.split("GOAL:", 1)[-1].split("GOAL PROGRESS", 1)[0]
    return set(NAME.findall(goal))


def unmet_checks(prompt: str) -> list[tuple[set[str], set[str]]]:
    """The object names and robots of each goal check GOAL PROGRESS shows unmet (✗)."""
    section = prompt.split("GOAL PROGRESS", 1)[-1].split("\n\n", 1)[0]
    return [(set(NAME.findall(line)), set(AGENT.findall(line)))
            for line in section.splitlines() if "[✗]" in line]


def features(observation: dict) -> tuple[np.ndarray, np.ndarray]:
    """Each legal entry's feature row, and its menu id (DONE is never offered: the baseline
    `random` never chooses it either)."""
    prompt = observation["prompt"]
    goal, unmet = goal_words(prompt), unmet_checks(prompt)
    width = len(VERBS) + 1
    rows, ids = [], []
    for line in observation["menu"].splitlines():
        match = MENU_LINE.match(line)
        if not match:
            continue
        agent, name = match.group(2), match.group(3)
        verb = next((i for i, v in enumerate(VERBS) if name.startswith(v)), len(VERBS))
        objects = set(NAME.findall(name))
        row = np.zeros(BLOCKS * width)
        row[verb] = 1
        if objects & goal:
            row[width + verb] = 1
        if any(objects & names and (not robots or agent in robots) for names, robots in unmet):
            row[2 * width + verb] = 1
        rows.append(row)
        ids.append(int(match.group(1)))
    return np.array(rows), np.array(ids)


#: A policy: given the environment (for the oracle's plan) and the feature rows and menu ids of
#: the legal entries, the menu id to play.
Policy = Callable[[object, np.ndarray, np.ndarray], int]


@dataclass(frozen=True)
class Scores:
    """Means over held-out episodes."""

    ret: float  # the return under the default rewards
    progress: float  # the result line's task_progress
    success: float  # the result line's task_success: the success rate

    def __str__(self) -> str:
        return (f"return {self.ret:+.3f}  progress {self.progress:.3f}  "
                f"SR {100 * self.success:.1f} %")


def play(environment, task_id: str, choose: Policy) -> tuple[float, list]:
    """One episode; its return and the (features, choice, reward) of each step the policy
    chose among the menu (a DONE is not one)."""
    observations, _ = environment.reset(options={"task_id": task_id})
    total, steps = 0.0, []
    while environment.agents:
        rows, ids = features(observations[SEAT])
        choice = choose(environment, rows, ids) if len(ids) else DONE
        observations, rewards, *_ = environment.step({SEAT: choice})
        total += rewards[SEAT]
        if choice != DONE:
            steps.append((rows, int(np.flatnonzero(ids == choice)[0]), rewards[SEAT]))
    return total, steps


def softmax(rows: np.ndarray, weights: np.ndarray) -> np.ndarray:
    logits = rows @ weights
    logits -= logits.max()
    p = np.exp(logits)
    return p / p.sum()


def evaluate(environment, tasks: list[str], choose: Policy) -> Scores:
    """`choose`'s mean return, progress and success rate over `tasks`."""
    returns, progress, success = [], [], []
    for task in tasks:
        returns.append(play(environment, task, choose)[0])
        progress.append(environment.state_result.task_progress)
        success.append(environment.state_result.task_success)
    return Scores(float(np.mean(returns)), float(np.mean(progress)), float(np.mean(success)))


def do_nothing(environment, rows: np.ndarray, ids: np.ndarray) -> int:
    return DONE


def uniform(rng: np.random.Generator) -> Policy:
    """`random`'s choice: uniform over the menu, never DONE."""
    return lambda environment, rows, ids: int(ids[int(rng.integers(len(ids)))])


class Oracle:
    """The reference plan's next call (DONE once it is through, or off the menu)."""

    def __init__(self) -> None:
        self.tools: object = None  # the episode's tools, made afresh by each reset
        self.plan: OraclePlan | None = None

    def __call__(self, environment, rows: np.ndarray, ids: np.ndarray) -> int:
        episode = environment.episode
        if self.tools is not episode.tools:
            self.tools, self.plan = episode.tools, OraclePlan(episode.episode)
        call = self.plan.next_call()
        entry = next((o for o in episode.view(SEAT).menu if o.call == call), None)
        return entry.action_id if entry is not None else DONE


class LinearPolicy:
    """The softmax policy over entry features, trained with REINFORCE."""

    def __init__(self, rng: np.random.Generator, rate: float = 0.05) -> None:
        self.rng, self.rate = rng, rate
        self.weights = np.zeros(BLOCKS * (len(VERBS) + 1))
        self.baseline = 0.0

    def __call__(self, environment, rows: np.ndarray, ids: np.ndarray) -> int:
        return int(ids[int(self.rng.choice(len(rows), p=softmax(rows, self.weights)))])

    def learn(self, total: float, steps: list) -> None:
        """One REINFORCE update: ∇ log π(a) × (G_t − b), b a running mean of returns."""
        self.baseline += 0.05 * (total - self.baseline)
        to_go = total
        for rows, index, reward in steps:
            p = softmax(rows, self.weights)
            self.weights += self.rate * (to_go - self.baseline) * (rows[index] - p @ rows)
            to_go -= reward


def train(environment, policy: LinearPolicy, tasks: list[str], episodes: int) -> None:
    """`episodes` episodes on instances drawn from `tasks`, each followed by an update."""
    for _ in range(episodes):
        total, steps = play(environment, tasks[int(policy.rng.integers(len(tasks)))], policy)
        policy.learn(total, steps)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=800, help="training episodes")
    parser.add_argument("--every", type=int, default=100, help="evaluate every N episodes")
    parser.add_argument("--plot", default=None, help="write the learning curve here (PNG)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--rate", type=float, default=0.05, help="REINFORCE's step size")
    parser.add_argument("--held-out", type=int, default=80,
                        help="measure on the first N of the 80 held-out instances")
    args = parser.parse_args()
    environment = parallel_env("cocobench-240", condition="C0_blind")
    tasks = [c.task_id for c in environment.configs]
    train_tasks, held_out = tasks[:160], tasks[160:160 + args.held_out]
    baselines = {"do nothing": evaluate(environment, held_out, do_nothing),
                 "random": evaluate(environment, held_out,
                                    uniform(np.random.default_rng(args.seed))),
                 "oracle": evaluate(environment, held_out, Oracle())}
    for name, scores in baselines.items():
        print(f"{name:>10} on the {len(held_out)} held-out instances: {scores}")
    policy = LinearPolicy(np.random.default_rng(args.seed), args.rate)
    curve = [(0, evaluate(environment, held_out, policy))]
    started = time.perf_counter()
    while curve[-1][0] < args.episodes:
        train(environment, policy, train_tasks, args.every)
        curve.append((curve[-1][0] + args.every, evaluate(environment, held_out, policy)))
        print(f"{curve[-1][0]:6} episodes  {time.perf_counter() - started:6.0f} s  "
              f"held-out {curve[-1][1]}")
    print(f"learned: {curve[-1][1]}")
    if args.plot:
        plot(curve, baselines, args.plot, len(held_out))


def plot(curve: list, baselines: dict[str, Scores], path: str, held_out: int) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, (progress, success) = plt.subplots(1, 2, figsize=(10, 3.6))
    episodes = [c[0] for c in curve]
    for axes, field, label in ((progress, "progress", "mean goal progress"),
                               (success, "success", "success rate")):
        axes.plot(episodes, [getattr(c[1], field) for c in curve], marker="o",
                  label="linear policy")
        for (name, scores), style in zip(baselines.items(), (":", "--", "-."), strict=True):
            axes.axhline(getattr(scores, field), color="grey", linestyle=style, label=name)
        axes.set_xlabel("training episodes (C0_blind, 160 instances)")
        axes.set_ylabel(f"{label}, {held_out} held-out")
    progress.legend(fontsize="small")
    figure.tight_layout()
    figure.savefig(path, dpi=120)


if __name__ == "__main__":
    main()
