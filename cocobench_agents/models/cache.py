"""On-disk response cache: one small JSON file per (model, messages, parameters, sample)."""

from __future__ import annotations

import dataclasses
import hashlib
import json
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from benchmark_adapter.trajectory import write_json_atomic

from .protocol import ModelReply

CACHE_FORMAT = 2  # bump when the key or the file layout changes: old entries then miss
_DATA_URL_PREFIX = "data:"


def cache_key(
    model: str, messages: list[dict[str, Any]], params: dict[str, Any], sample_index: int,
    *, endpoint: Mapping[str, Any] | None = None,
) -> str:
    """The hex sha256 naming a request: the model, the messages, every request parameter,
    the sample, and `endpoint`: where and how the model is reached and what is kept of its
    reply (`RemoteClient.cache_scope`: transport, api_base, the reply cap), since the same
    model name at two endpoints is two models. Images count by the sha256 of their data URL,
    so keys stay cheap to compute and the files small. Timeouts, retries and keys are not
    part of it (they do not change a reply)."""
    payload = {
        "format": CACHE_FORMAT,
        "endpoint": dict(endpoint or {}),
        "model": model,
        "messages": _hash_images(messages),
        "params": params,
        "sample_index": sample_index,
    }
    blob = json.dumps(payload, sort_keys=True, ensure_ascii=False, default=repr)
    return hashlib.sha256(blob.encode("utf-8")).hexdigest()


def _hash_images(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _hash_images(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_hash_images(v) for v in value]
    if isinstance(value, str) and value.startswith(_DATA_URL_PREFIX) and len(value) > 256:
        return "sha256:" + hashlib.sha256(value.encode("ascii", "replace")).hexdigest()
    return value


class ResponseCache:
    """Replies stored under ``DIR/<key[:2]>/<key>.json``.

    Writes are atomic (a temporary file in the same folder, then `os.replace`), so concurrent
    writers of one key, threads or processes, leave one complete file; a reader never sees a
    partial one. An unreadable or foreign file is a miss. A write that fails (full disk,
    read-only folder) is counted in `write_failures` and warned about once: the reply it
    was storing is still used.
    """

    def __init__(self, directory: str | Path) -> None:
        self.directory = Path(directory)
        self.write_failures = 0

    def path(self, key: str) -> Path:
        """The file holding `key`."""
        return self.directory / key[:2] / f"{key}.json"

    def get(self, key: str) -> ModelReply | None:
        """The stored reply with ``cached=True``, or None on a miss."""
        try:
            data = json.loads(self.path(key).read_text(encoding="utf-8"))
            if data.get("format") != CACHE_FORMAT or data.get("key") != key:
                return None
            reply = data["reply"]
            return ModelReply(
                text=str(reply["text"]),
                prompt_tokens=int(reply.get("prompt_tokens", 0)),
                completion_tokens=int(reply.get("completion_tokens", 0)),
                cost_usd=float(reply.get("cost_usd", 0.0)),
                latency_s=float(reply.get("latency_s", 0.0)),
                retries=int(reply.get("retries", 0)),
                cached=True,
                truncated_chars=int(reply.get("truncated_chars", 0)),
            )
        except (OSError, ValueError, KeyError, TypeError, AttributeError):
            return None

    def put(self, key: str, reply: ModelReply, *, model: str, sample_index: int) -> Path | None:
        """Store `reply` under `key`; returns the file written, or None when it could not be
        written (counted and warned about, never raised: the caller keeps its reply)."""
        try:
            return self._write(key, reply, model=model, sample_index=sample_index)
        except OSError as exc:
            self.write_failures += 1
            if self.write_failures == 1:
                warnings.warn(f"the response cache {self.directory} cannot be written "
                              f"({exc.strerror or exc}); replies are used but not cached",
                              RuntimeWarning, stacklevel=2)
            return None

    def _write(self, key: str, reply: ModelReply, *, model: str, sample_index: int) -> Path:
        record = {
            "format": CACHE_FORMAT,
            "key": key,
            "model": model,
            "sample_index": sample_index,
            "reply": {**dataclasses.asdict(reply), "cached": False},
        }
        # Atomic (temporary file, then rename): concurrent writers of one key leave one whole
        # file, and a reader never sees a part of one.
        return write_json_atomic(self.path(key), record)
