"""Spend limits of a run: stop starting episodes once the money or tokens asked for are spent.

Episodes in flight finish (their calls are already paid for); the rest stay pending, so
`--resume` with a higher limit completes the run. The counts live in shared memory, so worker
processes forked from the parent see what the parent has recorded.
"""

from __future__ import annotations

import multiprocessing
from collections.abc import Iterable
from typing import Any


class SpendLimit:
    """`--max-cost USD` and `--max-total-tokens N` over every result of the run folder."""

    def __init__(self, max_cost_usd: float | None = None, max_tokens: int | None = None,
                 *, spent: Iterable[dict[str, Any]] = ()) -> None:
        self.max_cost_usd, self.max_tokens = max_cost_usd, max_tokens
        self._cost = multiprocessing.Value("d", 0.0)
        self._tokens = multiprocessing.Value("q", 0)
        for record in spent:
            self.add(record)

    @property
    def active(self) -> bool:
        return self.max_cost_usd is not None or self.max_tokens is not None

    def add(self, record: dict[str, Any]) -> None:
        """Count one result's usage."""
        usage = record.get("usage") or {}
        with self._cost.get_lock():
            self._cost.value += float(usage.get("cost_usd") or 0.0)
        with self._tokens.get_lock():
            self._tokens.value += int(usage.get("prompt_tokens") or 0) + int(
                usage.get("completion_tokens") or 0)

    def reached(self) -> bool:
        """Whether no new episode may start."""
        return ((self.max_cost_usd is not None and self._cost.value >= self.max_cost_usd)
                or (self.max_tokens is not None and self._tokens.value >= self.max_tokens))

    def describe(self) -> str:
        """What was spent against which limit."""
        parts = []
        if self.max_cost_usd is not None:
            parts.append(f"${self._cost.value:.4f} of --max-cost {self.max_cost_usd:g}")
        if self.max_tokens is not None:
            parts.append(f"{self._tokens.value:,} of --max-total-tokens {self.max_tokens:,}")
        return ", ".join(parts)
