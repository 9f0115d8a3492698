"""The golden run: one fixed request whose every recorded field must stay the same across
refactors (issue 27: behaviour unchanged). `capture(out)` runs it into `out` and returns what
it recorded, times and paths aside; `python -m tests.engine.golden_run` rewrites the golden
file from the tree it runs in (do that only for an intended change of behaviour, and say so).

The request: two shared configs × C0/D0/D1 × image/blind, plus leader-worker and a plugin
planner (tests/planners/user_planner.py) under both observation modes, each with the `random`
and a `scripted` model (replies that act, message and miss).
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path
from typing import Any

from tests.paths import SHARED_TASKS

GOLDEN = Path(__file__).with_name("golden_run") / "records.json"
CONFIGS = ("A_D1__FloorPlan14__seed0.json", "K_D3__FloorPlan13__seed0.json")
CONDITIONS = "C0_image,C0_blind,D0_image,D0_blind,D1_image,D1_blind"
PLUGIN = str(Path(__file__).resolve().parents[1] / "planners" / "user_planner.py") + ":ONE_NODE"
SCRIPT = {"*": ["REASON: start with the first item\nACTION: 1\nMSG: I take the first one",
                "ACTION: 2", "no action here", "REASON: next\nACTION: 3\nMSG: done soon"]}
#: Fields that differ from run to run by design: wall times, and where the run folder lies
#: (the only ones the golden request records; built-in models report no latency).
VOLATILE = frozenset({"elapsed_s", "model_latency_s", "out"})


def _scrub(value: Any, root: str) -> Any:
    """`value` without volatile fields, with the run's own paths made relative."""
    if isinstance(value, dict):
        return {k: _scrub(v, root) for k, v in sorted(value.items()) if k not in VOLATILE}
    if isinstance(value, list):
        return [_scrub(v, root) for v in value]
    if isinstance(value, str):
        return value.replace(root, "<run>")
    return value


def _folder(out: Path) -> dict[str, Any]:
    """One run folder's records: its request, its result lines (sorted), its trajectories."""
    root = str(out.parent)
    repo = str(Path(__file__).resolve().parents[2])
    lines = [json.loads(line) for line in (out / "results.jsonl").read_text().splitlines()
             if line.strip()]
    lines.sort(key=lambda r: (r["model"], r["condition"], r["task_id"]))
    trajectories = {str(p.relative_to(out)): json.loads(p.read_text())
                    for p in sorted(out.glob("episodes/**/trajectory.json"))}
    run = json.loads((out / "run.json").read_text())
    records = {"request": run.get("request"), "results": lines, "trajectories": trajectories}
    text = json.dumps(_scrub(records, root))
    # run.json records paths resolved (a `shared` that is a link is followed).
    for tasks in sorted({str(SHARED_TASKS.resolve()), str(SHARED_TASKS)}, key=len, reverse=True):
        text = text.replace(tasks, "<tasks>")
    return json.loads(text.replace(repo, "<repo>"))


def capture(work: Path) -> dict[str, Any]:
    """Run the golden request into `work` (two run folders) and return what they hold."""
    from cocobench_agents.api import evaluate

    (work / "script.json").write_text(json.dumps(SCRIPT), encoding="utf-8")
    configs = [str(SHARED_TASKS / name) for name in CONFIGS]
    models = ["random", "scripted:script.json"]  # relative: the model's name holds its path
    here = os.getcwd()
    os.chdir(work)
    try:
        evaluate(configs, models=models, out=work / "conditions", conditions=CONDITIONS,
                 max_steps=6)
        evaluate(configs, models=models, out=work / "planners",
                 conditions="C0_image,C0_blind", planners=["leader-worker", PLUGIN],
                 max_steps=6)
    finally:
        os.chdir(here)
    return {"conditions": _folder(work / "conditions"), "planners": _folder(work / "planners")}


def main() -> None:
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        records = capture(Path(tmp))
    GOLDEN.parent.mkdir(exist_ok=True)
    GOLDEN.write_text(json.dumps(records, indent=1, sort_keys=True) + "\n", encoding="utf-8")
    print(f"wrote {GOLDEN}", file=sys.stderr)


if __name__ == "__main__":
    main()
