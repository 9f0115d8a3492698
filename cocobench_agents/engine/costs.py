"""What a dry run reports (`estimate`, `cocobench run … --dry-run`): a `CostPlan` of rows per
model × condition × arm, their total, every episode's first-prompt tokens, the run's power,
and the JSON object `--dry-run --json` prints (docs/dry-run.md)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from cocobench_agents.engine.power import Power


@dataclass(frozen=True)
class CostRange:
    """USD a run is estimated to spend: `low` and `high`, None when a model has no price."""

    low: float | None
    high: float | None

    @property
    def known(self) -> bool:
        return self.low is not None and self.high is not None

    def to_json(self) -> dict[str, float | None]:
        """Rounded to a millionth of a dollar (sums of float products carry noise below)."""
        return {"low": _usd(self.low), "high": _usd(self.high)}


def _usd(amount: float | None) -> float | None:
    return None if amount is None else round(amount, 6)


@dataclass(frozen=True)
class CostRow:
    """The estimate of one model × condition × arm."""

    model: str  # the run's model label (the team's model; "oracle" for the oracle)
    condition: str
    arm: str  # "" for a run without prompt-suite arms (null in JSON)
    episodes: int
    max_calls: int
    prompt_tokens: int  # summed over the episodes: each one's first decision round
    cost_usd: CostRange
    #: Every model the row's calls go to, the team's first (`--agent-model` adds others).
    models: tuple[str, ...] = ()
    #: max_calls assumes one call per agent per landed step: a planner whose spec declares no
    #: `loop` (a strategy that asks again within a round can exceed it).
    assumed: bool = False

    def to_json(self) -> dict[str, Any]:
        return {"model": self.model, "condition": self.condition, "arm": self.arm or None,
                "episodes": self.episodes, "max_calls": self.max_calls,
                "prompt_tokens": self.prompt_tokens, "cost_usd": self.cost_usd.to_json()}


@dataclass(frozen=True)
class EpisodeTokens:
    """One planned episode's first-prompt tokens (0 for the oracle's)."""

    model: str
    condition: str
    arm: str  # "" for a run without prompt-suite arms (null in JSON)
    task_id: str
    epoch: int
    prompt_tokens: int  # everything its first decision round sends to models

    def to_json(self) -> dict[str, Any]:
        return {"model": self.model, "condition": self.condition, "arm": self.arm or None,
                "task_id": self.task_id, "epoch": self.epoch,
                "prompt_tokens": self.prompt_tokens}


@dataclass(frozen=True)
class CostTotal:
    """The rows summed; the cost is unknown (None) when any row's is."""

    episodes: int
    max_calls: int
    prompt_tokens: int
    cost_usd: CostRange

    def to_json(self) -> dict[str, Any]:
        return {"episodes": self.episodes, "max_calls": self.max_calls,
                "prompt_tokens": self.prompt_tokens, "cost_usd": self.cost_usd.to_json()}


@dataclass(frozen=True)
class CostPlan:
    """What a planned run would spend, per model × condition × arm, in plan order."""

    rows: tuple[CostRow, ...]
    total: CostTotal
    #: model → the token counter its prompts were counted with (one line, for people).
    token_counters: Mapping[str, str] = field(default_factory=dict)
    max_cost_usd: float | None = None  # the run's --max-cost, if any
    #: Whether the low / high total exceeds `max_cost_usd`; None without a limit or a price.
    low_exceeds_max_cost: bool | None = None
    high_exceeds_max_cost: bool | None = None
    #: Every episode's first-prompt tokens, in plan order (a row's `prompt_tokens` sums them).
    episodes: tuple[EpisodeTokens, ...] = ()
    #: What the run can detect between two arms (`dry_run.plan` sets it; see `power`).
    power: Power | None = None

    def to_json(self) -> dict[str, Any]:
        """The `--dry-run --json` object: rows, total, token counters, the spend limit,
        every episode's first-prompt tokens and, from `plan`, the power."""
        limit = None
        if self.max_cost_usd is not None:
            limit = {"limit": self.max_cost_usd, "low_exceeds": self.low_exceeds_max_cost,
                     "high_exceeds": self.high_exceeds_max_cost}
        power = {} if self.power is None else {"power": self.power.to_json()}
        return {"rows": [row.to_json() for row in self.rows], "total": self.total.to_json(),
                "token_counters": dict(self.token_counters), "max_cost_usd": limit,
                "episodes": [episode.to_json() for episode in self.episodes], **power}
