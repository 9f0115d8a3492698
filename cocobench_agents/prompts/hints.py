"""The coordination hint: constraints a planner would otherwise never see (reference §6.1)."""

from __future__ import annotations

from benchmark_adapter.tasks import TaskConfig
from cocobench_agents.prompts.suite import PromptSuite


def coordination_hint(config: TaskConfig, suite: PromptSuite) -> str:
    """The K resource hint, the D4 relay hint, or "" (D1/D2, or the `no-hint` variant)."""
    if "no-hint" in suite.variants:
        return ""
    constraints = config.task_constraints
    if constraints.get("resource_exclusion"):
        return suite.render("hint_resource")
    relay = constraints.get("producer_consumer")
    if not relay:
        return ""
    alias = {oid: name for name, oid in config.init_state.objects.items()}
    buffer = relay.get("buffer")
    targets = relay.get("targets") or []
    return suite.render(
        "hint_relay",
        buffer=alias.get(buffer, buffer),
        producer=", ".join(sorted(config.producers())) or "the producer",
        consumer=", ".join(sorted(config.consumers())) or "the consumer",
        targets=", ".join(alias.get(t, t) for t in targets) or "the destination",
    )
