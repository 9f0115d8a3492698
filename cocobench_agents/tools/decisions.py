"""Decision records: one per model call (or stop), in the reference's `policy_decision` shape
plus what an evaluation harness needs (prompt hash, latency, tokens, cost, retries)."""

from __future__ import annotations

import functools
import hashlib
from typing import Any

from cocobench_agents.models.protocol import ModelError, ModelReply
from cocobench_agents.prompts import ParsedReply


@functools.lru_cache(maxsize=64)  # a decision's prompt is hashed when kept and when recorded
def prompt_hash(prompt: str) -> str:
    """Short stable fingerprint of a rendered prompt."""
    return hashlib.sha256(prompt.encode("utf-8")).hexdigest()[:16]


def model_decision(*, policy: str, model: str, agent: str | None, step_index: int,
                   prompt: str, parsed: ParsedReply | None, call: str | None,
                   reply: ModelReply | None = None, error: ModelError | None = None,
                   message: str = "") -> dict[str, Any]:
    """The record of one model call: its parse outcome or its backend error."""
    status = "backend_error" if error else parsed.status
    record: dict[str, Any] = {
        "policy": policy, "backend": _provider(model), "model": model, "agent": agent,
        "step_index": step_index, "status": status,
        "terminal_reason": None if call else status,
        "parsed_action_id": parsed.raw_choice if parsed else None,
        "parsed_call": call, "parse_mode": parsed.mode if parsed else None,
        "prompt_hash": prompt_hash(prompt),
    }
    if reply is not None:
        record.update(reply_fields(reply))
    if error is not None:
        record.update(error=str(error), error_kind=error.kind, retries=error.retries,
                      latency_s=round(error.latency_s, 4))
    elif parsed is not None and parsed.error:
        record["error"] = parsed.error
    if message:
        record["message"] = message
    return record


def reply_fields(reply: ModelReply) -> dict[str, Any]:
    """What a decision record keeps of a model's reply: its text, latency, usage, retries,
    whether it was reused (``cached``, ``replayed``) and, for a reply cut at the size cap,
    how many characters were dropped from its end. A reused reply was not paid for now: its
    tokens, cost, latency and retries are 0, and what its model call had cost is kept under
    ``saved``."""
    usage = {"latency_s": round(reply.latency_s, 4), "prompt_tokens": reply.prompt_tokens,
             "completion_tokens": reply.completion_tokens, "cost_usd": reply.cost_usd}
    fields: dict[str, Any] = {"raw_output": reply.text, **usage, "retries": reply.retries,
                              "cached": reply.cached, "replayed": reply.replayed}
    if reply.reused:
        fields.update(dict.fromkeys(usage, 0), retries=0, saved=usage)
    if reply.truncated_chars:
        fields["reply_truncated_chars"] = reply.truncated_chars
    return fields


def stop_decision(*, policy: str, model: str | None, agent: str | None, step_index: int,
                  status: str) -> dict[str, Any]:
    """A decision without a model call: an empty menu, the step budget, an all-idle round."""
    return {"policy": policy, "backend": _provider(model) if model else None, "model": model,
            "agent": agent, "step_index": step_index, "status": status,
            "parsed_call": None, "terminal_reason": status}


def _provider(model: str) -> str:
    """The backend part of a model string: `openai/gpt-4o` → `openai`, `random:3` → `random`,
    `replay:/runs/a` → `replay`."""
    head = model.split("/", 1)[0]
    return head.split(":", 1)[0] if ":" in head else head
