"""What `run.json` records, and which episodes of a plan are still to run."""

from __future__ import annotations

import datetime as dt
import platform
from collections.abc import Sequence
from importlib import metadata
from pathlib import Path
from typing import Any

from cocobench_agents import __version__
from cocobench_agents.graphs.plugins import planners_record
from cocobench_agents.harness.infra import is_infra_failure
from cocobench_agents.harness.plan import PlannedEpisode, RunOptions
from cocobench_agents.harness.store import RunFolder
from cocobench_agents.models import ModelSettings, is_builtin, redact
from cocobench_agents.prompts import load_prompt_suite

PACKAGES = ("cocobench-agents", "langgraph", "litellm", "pydantic", "pillow", "ai2thor")


def run_record(out: str, request: dict[str, Any], settings: ModelSettings,
               argv: Sequence[str]) -> dict[str, Any]:
    """Everything needed to reproduce the run (no secrets)."""
    options = request["options"]
    return {
        "name": Path(out).name,
        "created_at": dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds"),
        "cocobench_agents": __version__,
        "versions": {"python": platform.python_version(), **_package_versions()},
        **_suites_record(options),
        # planners from the researcher's code: code, origin, file hash (guards a resume)
        "planners": planners_record(c.planner for c in request["conditions"]),
        "plan": {"sources": request["sources"], "task_ids": request["task_ids"],
                 "models": request["models"], "agent_models": request["agent_models"],
                 "conditions": [c.name for c in request["conditions"]],
                 **({"arms": list(options.arms)} if options.arms else {}),
                 **({"planner_arms": request["planner_arms"]}
                    if request.get("planner_arms") else {}),
                 "epochs": request["epochs"]},
        "options": {"backend": options.backend, "max_steps": options.max_steps,
                    "stable_ids": options.stable_ids},
        "model_settings": settings.to_record(),
        # What "auto" resolved to, per remote model: the temperature sent (None: none sent).
        "temperature_sent": {
            model: settings.temperature_for(model)
            for model in dict.fromkeys([*request["models"], *request["agent_models"].values()])
            if not is_builtin(model) and model != "oracle"},
        "request": _replayable_request(request),
        "command": redact(" ".join(argv), settings.secrets()),
    }


def _replayable_request(request: dict[str, Any]) -> dict[str, Any]:
    """The options a bare `--resume` needs to plan the same episodes again."""
    options = request["options"]
    return {"tasks": request["sources"], "suite": None, "models": request["models"],
            "agent_models": [f"{a}={m}" for a, m in request["agent_models"].items()],
            "conditions": ",".join(c.name for c in request["conditions"]),
            "epochs": request["epochs"], "task_id": request["task_ids"], "eval_set": (),
            "only_cell": None, "only_family": None, "only_dim": None, "limit": 0,
            "prompt_suite": list(options.arms.values()) or options.prompt_suite,
            "backend": options.backend,
            "max_steps": options.max_steps, "stable_ids": options.stable_ids}


def _suites_record(options: RunOptions) -> dict[str, Any]:
    """The prompt suite (spec, version, content hash, a folder's path), or with arms each
    arm's suite: what `--resume` checks the suites against."""
    if not options.arms:
        return {"prompt_suite": load_prompt_suite(options.prompt_suite).record()}
    return {"prompt_suites": [{"arm": arm, **load_prompt_suite(spec).record()}
                              for arm, spec in options.arms.items()]}


def _package_versions() -> dict[str, str]:
    out = {}
    for name in PACKAGES:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            continue
    return out


def pending_episodes(episodes: Sequence[PlannedEpisode], folder: RunFolder, *,
                     retry_errors: bool = False) -> list[PlannedEpisode]:
    """The planned episodes without a valid result line and trajectory (plus infrastructure
    failures, when asked: see `is_infra_failure`). An episode whose latest line is invalid
    or whose trajectory is missing counts as not done (`RunFolder.scan_results`)."""
    done = folder.scan_results(check_trajectories=True).done
    return [p for p in episodes
            if p.key not in done or (retry_errors and is_infra_failure(done[p.key]))]
