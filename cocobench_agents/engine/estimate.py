"""What a planned run would cost before it runs: episodes, the most model calls its step
budgets allow, the tokens of every episode's first prompt and a cost range in USD, per
model × condition × arm (`cocobench run … --dry-run`, `cocobench_agents.plan`; see
docs/dry-run.md).

Nothing here calls a model, starts a simulator other than the embedded one, or writes a file:
first prompts are rendered as the model clients would send them (`first_prompts`), counted
with LiteLLM's token counter and priced from the cost map LiteLLM ships, read offline
(`pricing`); the figures are a `CostPlan` (`costs`). This module adds them up.

Definitions (the docs give the reasons):

* An episode's **first prompt tokens** are what its first decision round sends to models:
  the team's prompt (C0); every agent's prompt (D0, D1); the leader's prompt and every
  agent's prompt (leader–worker); and each of a planner's own templates (`ask`) once per
  seat, its strategy's fields as `{name}`. Each prompt is counted with the tokenizer of the
  model it goes to (`--agent-model` teams mix them). The oracle sends none (0).
* **max_calls** bounds the model calls of an episode from its step budget B (`--max-steps`,
  else `difficulty.step_budget`): C0 asks once per landed step (B); D0/D1 ask every one of
  the N agents each round, and a round lands at least one step or ends the episode (N × B);
  leader–worker adds the leader's call to every round ((N + 1) × B); the oracle asks none.
  Each planner's `PlannerSpec` declares this shape (its `loop`, `prompt`, `broadcast` and
  `calls_per_seat`; `PlannerSpec.most_calls`), a plugin's as a built-in's; one that declares
  no `loop` is assumed to ask N × B (`CostRow.assumed`). Retries are not counted.
* **cost low** = each seat's first prompt × the calls of a run as short as the oracle's plan
  (its calls for C0, its busiest agent's calls, i.e. rounds, for teams) × input price (a
  strategy's own asks may never be made: not counted).
  **cost high** = max_calls × the row's largest single first prompt × input price, plus
  max_calls × `max_tokens` × output price when `max_tokens` is set. Built-in models are free
  (0); a model without a price in the cost map has unknown cost (None), and so has the total.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from types import ModuleType
from typing import TYPE_CHECKING

from benchmark_adapter.tasks import TaskConfig
from cocobench_agents.engine.costs import CostPlan, CostRange, CostRow, CostTotal, EpisodeTokens
from cocobench_agents.engine.first_prompts import FirstRounds
from cocobench_agents.engine.pricing import TokenCounter, price_per_token
from cocobench_agents.graphs import PlannerSpec, planner_spec
from cocobench_agents.graphs.registry import STEP
from cocobench_agents.models import import_litellm

if TYPE_CHECKING:
    from cocobench_agents.harness.episodes import PlannedEpisode
    from cocobench_agents.models import ModelSettings

__all__ = ["CostPlan", "estimate"]


# -- calls ---------------------------------------------------------------------------------

def _oracle_length(config: TaskConfig) -> tuple[int, int]:
    """(calls, busiest agent's calls) of the instance's oracle plan; an instance without one
    counts as a single call (an episode asks at least once)."""
    from benchmark_adapter.generator.oracles import oracle_stats

    try:
        stats = oracle_stats(config)
    except LookupError:  # no plan for this task type, or one needing an alias it lacks
        return 1, 1
    return stats.calls, stats.makespan


def _seat_calls(planner: PlannerSpec, agents: int, budget: int, oracle: tuple[int, int]
                ) -> tuple[int, int]:
    """(most, oracle-short) calls of one seat over an episode of step budget `budget`.

    The most are what the planner's spec declares (`PlannerSpec.seat_calls`: at most
    `budget` rounds); a run as short as the oracle's plan asks each seat once per round and
    takes its calls (a step loop) or its busiest agent's calls (rounds)."""
    calls, makespan = oracle
    short = calls if planner.loop_kind == STEP else makespan
    return planner.seat_calls(agents, budget), min(short, budget)


# -- the estimate --------------------------------------------------------------------------

@dataclass
class _ModelShare:
    """What one row sends to one model."""

    max_calls: int = 0
    low_tokens: int = 0  # Σ first-prompt tokens × oracle-short calls
    largest_prompt: int = 0  # the largest single first prompt of the row


@dataclass
class _RowSum:
    episodes: int = 0
    max_calls: int = 0
    prompt_tokens: int = 0
    assumed: bool = False
    shares: dict[str, _ModelShare] = field(default_factory=dict)


def estimate(episodes: Sequence[PlannedEpisode], settings: ModelSettings, *,
             max_cost_usd: float | None = None) -> CostPlan:
    """Estimate `episodes` (a run's plan) without calling any model or writing anything.

    Per model × condition × arm, in plan order: the episodes, the most model calls their
    step budgets allow (retries not included), the tokens of each episode's first decision
    round (every prompt it sends, counted with its own model's tokenizer), and a cost range
    in USD (None for a model without a price). `settings.max_tokens` bounds the completion
    cost in `high`; without it completions are left out. With `max_cost_usd`, says whether the
    low and high totals exceed it.

    Measured on 2 quiet cores: cocobench-240 × the six paper conditions (1,440 episodes) in
    11.5 s with a remote model (most of it encoding the image conditions' frames) and 3.1 s
    with a built-in one, plus LiteLLM's import (about 7 s) on first use."""
    tally = _Tally(import_litellm())
    for planned in episodes:
        tally.add(planned)
    prices = {model: price_per_token(tally.litellm, model) for model in tally.counters}
    rows = tuple(_cost_row(key, row, prices, settings.max_tokens)
                 for key, row in tally.rows.items())
    total = _total(rows)
    return CostPlan(
        rows=rows, total=total,
        token_counters={model: c.description for model, c in tally.counters.items()},
        max_cost_usd=max_cost_usd,
        low_exceeds_max_cost=_exceeds(total.cost_usd.low, max_cost_usd),
        high_exceeds_max_cost=_exceeds(total.cost_usd.high, max_cost_usd),
        episodes=tuple(tally.episodes))


class _Tally:
    """Adds up a plan's episodes, row by row and model by model."""

    def __init__(self, litellm: ModuleType) -> None:
        self.litellm = litellm
        self.rows: dict[tuple[str, str, str], _RowSum] = {}
        self.counters: dict[str, TokenCounter] = {}  # by model, in order of first use
        self.episodes: list[EpisodeTokens] = []  # in plan order
        self._rounds = FirstRounds()
        self._oracle: dict[int, tuple[int, int]] = {}  # by config object

    def add(self, planned: PlannedEpisode) -> None:
        key = planned.key
        row = self.rows.setdefault((key.model, key.condition, key.arm), _RowSum())
        before = row.prompt_tokens
        self._count(planned, row)
        self.episodes.append(EpisodeTokens(key.model, key.condition, key.arm, key.task_id,
                                           key.epoch, row.prompt_tokens - before))

    def _count(self, planned: PlannedEpisode, row: _RowSum) -> None:
        """Add the episode's calls, first-prompt tokens and cost shares to its row."""
        spec = planned.spec
        row.episodes += 1
        planner = planner_spec(spec.planner)
        if not planner.uses_models:  # the oracle: no model, no call
            return
        row.assumed = row.assumed or not planner.declares_loop
        oracle = self._oracle_length(spec.config)
        most, short = _seat_calls(planner, spec.config.agent_count, spec.budget, oracle)
        for request in self._rounds.requests(spec, planner):
            tokens = self._counter(request.model).count(request.messages)
            share = row.shares.setdefault(request.model, _ModelShare())
            share.largest_prompt = max(share.largest_prompt, tokens)
            row.prompt_tokens += tokens
            if request.template is None:  # a seat's decision; its asks are among its calls
                share.max_calls += most
                share.low_tokens += tokens * short
                row.max_calls += most

    def _counter(self, model: str) -> TokenCounter:
        counter = self.counters.get(model)
        if counter is None:
            counter = self.counters[model] = TokenCounter(self.litellm, model)
        return counter

    def _oracle_length(self, config: TaskConfig) -> tuple[int, int]:
        length = self._oracle.get(id(config))
        if length is None:
            length = self._oracle[id(config)] = _oracle_length(config)
        return length


def _cost_row(key: tuple[str, str, str], row: _RowSum,
              prices: Mapping[str, tuple[float, float] | None],
              max_tokens: int | None) -> CostRow:
    low = high = 0.0
    for model, share in row.shares.items():
        price = prices[model]
        if price is None:
            low = high = None
            break
        price_in, price_out = price
        low += share.low_tokens * price_in
        high += share.max_calls * share.largest_prompt * price_in
        if max_tokens is not None:
            high += share.max_calls * max_tokens * price_out
    model, condition, arm = key
    return CostRow(model, condition, arm, row.episodes, row.max_calls, row.prompt_tokens,
                   CostRange(low, high), tuple(row.shares), row.assumed)


def _total(rows: Sequence[CostRow]) -> CostTotal:
    known = all(row.cost_usd.known for row in rows)
    return CostTotal(
        episodes=sum(row.episodes for row in rows),
        max_calls=sum(row.max_calls for row in rows),
        prompt_tokens=sum(row.prompt_tokens for row in rows),
        cost_usd=CostRange(sum(row.cost_usd.low for row in rows) if known else None,
                           sum(row.cost_usd.high for row in rows) if known else None))


def _exceeds(cost: float | None, limit: float | None) -> bool | None:
    return None if cost is None or limit is None else cost > limit
