"""The `replay` built-in: answer with the replies recorded in an earlier run's trajectories."""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from .errors import ModelConfigError
from .protocol import ModelError, ModelReply, ModelRequest

TRAJECTORY_FILE = "trajectory.json"


def recorded_replies(data: dict) -> dict[str | None, list[ModelReply]]:
    """agent (None for a centralized planner) → its recorded replies, in order, marked
    ``replayed`` and carrying what the original model call cost (its ``saved`` figures if it
    was itself reused).

    Read from the top-level ``planner_decisions`` list when present, else from the
    ``policy_decision`` of the ``trajectory`` items (the reference's format). Decisions with no
    raw output (the model was not asked, or failed) are skipped.
    """
    decisions = data.get("planner_decisions")
    if not isinstance(decisions, list) or not decisions:
        items = data.get("trajectory")
        decisions = [
            item["policy_decision"]
            for item in (items if isinstance(items, list) else [])
            if isinstance(item, dict) and isinstance(item.get("policy_decision"), dict)
        ]
    replies: dict[str | None, list[ModelReply]] = {}
    for decision in decisions:
        if not isinstance(decision, dict):
            continue
        raw = decision.get("raw_output")
        if isinstance(raw, str):
            agent = decision.get("agent")
            replies.setdefault(None if agent is None else str(agent), []).append(
                ModelReply(text=raw, replayed=True, **_original_usage(decision)))
    return replies


def _original_usage(decision: dict) -> dict[str, Any]:
    """What the recorded call cost the model (0 for figures a record lacks or garbles)."""
    saved = decision.get("saved")
    usage = saved if isinstance(saved, dict) else decision
    out: dict[str, Any] = {}
    for name, kind in (("prompt_tokens", int), ("completion_tokens", int),
                       ("cost_usd", float), ("latency_s", float)):
        try:
            out[name] = kind(usage.get(name) or 0)
        except (TypeError, ValueError):
            out[name] = kind(0)
    return out


def _episode_parts(episode: str) -> list[str]:
    return [p for p in episode.replace("\\", "/").split("/") if p]


class ReplaySource:
    """A ``replay:PATH`` source: one ``trajectory.json`` file, or a folder searched
    recursively for them. The folder is indexed once (task id → files)."""

    def __init__(self, path: str | Path, spec: str | None = None) -> None:
        self.path = Path(path)
        self.spec = spec or f"replay:{path}"
        self._index: dict[str, list[Path]] | None = None

    def check(self) -> None:
        """Raise `ModelConfigError` unless the source exists and holds at least one
        readable trajectory."""
        if not self.path.exists():
            raise ModelConfigError(self.spec, f"{self.path} does not exist")
        if self.path.is_file():
            self._load(self.path, config_error=True)
        elif not self.index():
            raise ModelConfigError(self.spec, f"no readable {TRAJECTORY_FILE} under {self.path}")

    def index(self) -> dict[str, list[Path]]:
        """task id → trajectory files, built on first use."""
        if self._index is None:
            index: dict[str, list[Path]] = {}
            files = [self.path] if self.path.is_file() else sorted(self.path.rglob(TRAJECTORY_FILE))
            for file in files:
                try:
                    task_id = self._load(file).get("task_id")
                except ModelError:
                    continue  # a broken file in a big folder must not hide the others
                if isinstance(task_id, str):
                    index.setdefault(task_id, []).append(file)
            self._index = index
        return self._index

    def _load(self, file: Path, *, config_error: bool = False) -> dict:
        try:
            data = json.loads(file.read_text(encoding="utf-8"))
            if not isinstance(data, dict):
                raise ValueError("not a JSON object")
        except (OSError, ValueError) as exc:
            message = f"cannot read {file}: {exc}"
            if config_error:
                raise ModelConfigError(self.spec, message) from None
            raise ModelError("other", f"{self.spec}: {message}") from None
        return data

    def find(self, episode: str) -> Path:
        """The trajectory recorded for `episode` (a task id, or a key whose path components
        include the task id, such as ``condition/task_id``); `ModelError` if none or several."""
        parts = _episode_parts(episode)
        index = self.index()
        matches = [f for task_id, files in index.items() if task_id in parts for f in files]
        if len(matches) > 1:
            # Several runs of one task (conditions, epochs): the folder path must say which.
            # The key's leading parts (this run's model) may not be in the recorded path, so
            # the longest tail of the key that some recorded folder ends with decides.
            for start in range(len(parts)):
                tail = "/" + "/".join(parts[start:])
                narrowed = [f for f in matches if f.parent.as_posix().endswith(tail)]
                if narrowed:
                    matches = narrowed
                    break
        if not matches:
            raise ModelError("other", f"{self.spec}: no recorded trajectory for {episode!r}")
        if len(matches) > 1:
            raise ModelError(
                "other",
                f"{self.spec}: {len(matches)} recorded trajectories match {episode!r}; "
                "point replay at a narrower folder",
            )
        return matches[0]

    def replies(self, episode: str) -> dict[str | None, list[ModelReply]]:
        """agent → recorded replies of `episode`."""
        return recorded_replies(self._load(self.find(episode)))


class ReplayClient:
    """Answers one agent of one episode with its recorded replies, in order; raises
    `ModelError` (kind ``other``) when none is left or no trajectory matches the episode."""

    accepts_images = False  # built-ins never look at frames: don't render them

    def __init__(self, name: str, source: ReplaySource, *, episode: str, agent: str | None):
        self.name = name
        self.source = source
        self.episode = episode
        self.agent = agent
        self._replies: Sequence[ModelReply] | None = None
        self._next = 0

    async def complete(self, request: ModelRequest) -> ModelReply:
        """The next recorded reply (``replayed``: billed 0, its original cost "saved")."""
        if self._replies is None:
            self._replies = self.source.replies(self.episode).get(self.agent, [])
        if self._next >= len(self._replies):
            who = "the centralized planner" if self.agent is None else self.agent
            raise ModelError(
                "other",
                f"{self.name}: replay exhausted: {len(self._replies)} recorded replies "
                f"for {who} in {self.episode!r}",
                extra={"replayed": len(self._replies)},
            )
        self._next += 1
        return self._replies[self._next - 1]
