"""What the runs page shows of one episode: one row of filterable, sortable columns."""

from __future__ import annotations

from typing import Any

from cocobench_agents.conditions import split_condition
from cocobench_agents.runfolder.infra import unanswered_calls
from cocobench_agents.viewer.paths import path_part
from cocobench_agents.viewer.source import Episode

#: (key, header, filterable): the runs page's columns, in order.
COLUMNS: tuple[tuple[str, str, bool], ...] = (
    ("run", "run", True),
    ("model", "model", True),
    ("condition", "condition", True),
    ("arm", "arm", True),
    ("task_id", "instance", False),
    ("cell", "cell", True),
    ("dim", "dim", True),
    ("family", "family", True),
    ("agents", "agents", True),
    ("success", "success", True),
    ("progress", "progress", False),
    ("cs", "CS", False),
    ("construct_status", "construct", True),
    ("terminal", "terminal", True),
    ("steps", "steps", False),
    ("errors", "errors", True),
)
FILTERS = tuple(key for key, _, filterable in COLUMNS if filterable)


def episode_row(episode: Episode, run_name: str) -> dict[str, Any]:
    """The runs-page row of an episode's latest result line: `k` a stable id (a later line
    of the episode replaces its row live), `h` its page, `c` its instance's compare page,
    `v` the cells in `COLUMNS` order (text)."""
    r = episode.record
    steps = r.get("num_steps")
    cells = {
        "run": run_name,
        "model": team_label(r),
        "condition": episode.key.condition,
        "arm": str(r.get("arm") or split_condition(episode.key.condition)[0]),
        "task_id": episode.key.task_id + (f" @e{episode.key.epoch}" if episode.key.epoch
                                          else ""),
        "cell": str(r.get("cell") or ""),
        "dim": str(r.get("dim") or ""),
        "family": str(r.get("family") or ""),
        "agents": str(r.get("agent_count") or ""),
        "success": "yes" if r.get("task_success") else "no",
        "progress": _fixed(r.get("task_progress")),
        "cs": _fixed(r.get("construct_score")),
        "construct_status": str(r.get("construct_status") or ""),
        "terminal": str(r.get("terminal_reason") or ""),
        "steps": "" if steps is None else str(steps),
        "errors": error_label(r),
    }
    return {"k": f"{episode.run}/{episode.key.folder()}", "h": episode.path,
            "c": compare_path(episode.key.task_id), "v": [cells[key] for key, _, _ in COLUMNS]}


def seat_models(record: dict[str, Any]) -> dict[str, str]:
    """Each seat's model, for a team whose seats differ (a human–AI team, `--agent-model`):
    the result line's `models`; empty for a team of one model. A seat whose model is not
    text (a line no run writes) is left out."""
    models = record.get("models")
    if not isinstance(models, dict):
        return {}
    seats = {str(agent): model for agent, model in models.items() if isinstance(model, str)}
    return seats if len(set(seats.values())) > 1 else {}


def team_label(record: dict[str, Any]) -> str:
    """Who played: the model, or each seat's model (`agent_1: human · agent_2: greedy`) in a
    team whose seats differ."""
    seats = seat_models(record)
    if seats:
        return " · ".join(f"{agent}: {model}" for agent, model in seats.items())
    return str(record["model"])


def error_label(record: dict[str, Any]) -> str:
    """What went wrong outside the model's choices: "infra: <reason>" for an episode the
    harness or simulator ended, "planner: <headline>" for one the strategy's own code ended,
    the counts of backend and parse errors, else "none"."""
    infra = record.get("infra_error")
    parts = [f"infra: {infra}" if isinstance(infra, str) else "infra"] if infra else []
    planner = record.get("planner_error")
    if planner:  # its headline: the traceback's frames are on the episode's page
        headline = planner.splitlines()[0] if isinstance(planner, str) else ""
        parts.append(f"planner: {headline}" if headline else "planner")
    for name, count in (("backend", unanswered_calls(record)),
                        ("parse", record.get("parse_errors"))):
        if isinstance(count, int) and count > 0:
            parts.append(f"{name} {count}")
    return ", ".join(parts) or "none"


def compare_path(task_id: str) -> str:
    """The compare page of one instance (every episode of it, side by side)."""
    return f"compare/{path_part(task_id)}.html"


def _fixed(value: Any) -> str:
    return f"{value:.2f}" if isinstance(value, (int, float)) else ""
