"""Trajectory records in the reference's `trajectory.json` format (reference §9.1)."""

from __future__ import annotations

import json
import os
import re
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import orjson

from benchmark_adapter.tasks.config import TaskConfig

# Integer keys become strings, as json.dumps makes them.
#: A field of our trajectories (beyond the reference's): the text of the prompts that its
#: planner decisions name by `prompt_hash`. A run folder keeps them in a compressed file of
#: the episode's own instead.
PROMPTS_FIELD = "prompts"

_ORJSON_OPTIONS = orjson.OPT_INDENT_2 | orjson.OPT_NON_STR_KEYS

# Object fields the reference records per step, plus isOpen/isSliced (harmless extras that
# make a trajectory self-explanatory).
STATE_FIELDS = (
    "visible",
    "isDirty",
    "isFilledWithLiquid",
    "fillLiquid",
    "isToggled",
    "parentReceptacles",
    "isOpen",
    "isSliced",
)


def state_record(config: TaskConfig, objects: Sequence[Mapping[str, Any]],
                 agents: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """The `state` of a step: important objects (agent 0's view) and every agent's hand
    (`inventoryObjects`, `lastActionSuccess`, `errorMessage` per agent, in config order)."""
    by_id = {o["objectId"]: o for o in objects}
    objects = {}
    for alias, oid in config.init_state.objects.items():
        obj = by_id.get(oid)
        objects[alias] = (
            {"objectId": oid, **{k: obj.get(k) for k in STATE_FIELDS}}
            if obj
            else {"objectId": oid, "missing": True}
        )
    agents = [
        {
            "agent": agent_id,
            "inventory": [o["objectId"] for o in md["inventoryObjects"]],
            "lastActionSuccess": bool(md["lastActionSuccess"]),
            "errorMessage": md["errorMessage"] or "",
        }
        for agent_id, md in zip(config.agent_ids, agents)
    ]
    return {"objects": objects, "agents": agents}


def trajectory_document(
    config: TaskConfig, init_trace: list[dict[str, Any]], items: list[dict[str, Any]]
) -> dict[str, Any]:
    """The whole `trajectory.json`; `final_eval` is the eval of the last item."""
    final = items[-1]["eval"] if items else {"success": False, "checks": []}
    return {
        "task_id": config.task_id,
        "task_config": config.to_json_dict(),
        "init_trace": init_trace,
        "final_eval": final,
        "trajectory": items,
    }


def dumps(document: Mapping[str, Any]) -> str:
    """Canonical JSON text (same document → same bytes): the bytes of
    ``json.dumps(document, indent=2, ensure_ascii=False)`` (NaN, which a trajectory never
    holds, would become null), written by orjson in a fortieth of the time: the standard
    library's indenting encoder is pure Python, and every episode writes a trajectory."""
    return orjson.dumps(document, option=_ORJSON_OPTIONS).decode() + "\n"


def write_json_atomic(path: str | Path, document: Mapping[str, Any]) -> Path:
    """Write JSON so that a reader never sees a half-written file."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(dumps(document))
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def load_trajectory(path: str | Path) -> dict[str, Any]:
    """Read a `trajectory.json` (ours or the reference's): `ValueError` when it is not UTF-8
    JSON text (`json_text`), `RecursionError` when it is nested too deep to read."""
    with open(path, "rb") as f:
        return json_text(f.read())


#: A JSON escape of a UTF-16 surrogate (``\ud800``): valid JSON, but alone it is no
#: character, and no text holding it can be written as UTF-8 (a page, a table, a file).
_SURROGATE_ESCAPE = re.compile(rb"\\u[dD][89a-fA-F][0-9a-fA-F]{2}")


def json_text(raw: bytes) -> Any:
    """The JSON document `raw` holds; `ValueError` when it is not UTF-8, not JSON, or holds a
    lone surrogate (a pair, an escaped emoji, is a character and is kept). Readers of run
    folders take text through here, so that nothing they read fails later when written."""
    value = json.loads(raw.decode("utf-8"))
    if _SURROGATE_ESCAPE.search(raw):  # rare: only then is the whole document checked
        try:
            json.dumps(value, ensure_ascii=False).encode("utf-8")
        except UnicodeEncodeError as exc:
            raise ValueError(f"not text: a lone surrogate (\\u{ord(exc.object[exc.start]):04x}) "
                             "that no UTF-8 file can hold") from None
    return value
