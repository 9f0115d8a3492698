"""The built-in suites as files: what they contain, writing them, checking shipped copies.

Layout under a suites root (by default the package data folder, where `load_tasks(name)`
finds suites by name):

    cocobench-full/<cell>/<task_id>.json               897 instances
    cocobench-full/subsets/cocobench-240.json          the subset, as a reference subset file
    cocobench-240/<cell>/<task_id>.json                the same 240 configs, loadable by name

The subset file makes `load_tasks(".../cocobench-full/subsets/cocobench-240.json")` and
`select_tasks(index=...)` work as with the reference's rep240.json; the folder makes
`load_tasks("cocobench-240")` work.
"""

from __future__ import annotations

import shutil
import tempfile
from collections import Counter
from importlib import resources
from pathlib import Path
from typing import Any

from benchmark_adapter.generator.composition import SUBSET_SEED, subset_ids
from benchmark_adapter.generator.jsonfmt import dumps
from benchmark_adapter.generator.pipeline import StratumResult
from benchmark_adapter.vocabulary import FULL_SUITE as FULL
from benchmark_adapter.vocabulary import SUBSET_SUITE as SUBSET

SUITES = (FULL, SUBSET)
SUBSET_FILE = f"subsets/{SUBSET}.json"


def package_data_root() -> Path:
    """The folder the built-in suites ship in (`benchmark_adapter/data`)."""
    return Path(str(resources.files("benchmark_adapter") / "data"))


def suite_configs(results: list[StratumResult]) -> dict[str, list[dict[str, Any]]]:
    """The configs of each suite, in task-id order."""
    full = sorted((c for r in results for c in r.kept), key=lambda c: c["task_id"])
    rows = [
        (c["task_id"], c["coordination_dim"], c["agent_count"], c["provenance"]["template"])
        for c in full
    ]
    chosen = set(subset_ids(rows))
    return {FULL: full, SUBSET: [c for c in full if c["task_id"] in chosen]}


def subset_document(configs: list[dict[str, Any]]) -> dict[str, Any]:
    """The subset file, shaped like the reference's rep240.json."""
    return {
        "name": SUBSET,
        "description": "Representative subset of 240 instances, stratified by dim x "
        "agent_count x task type (20 per dim x agent_count)",
        "seed": SUBSET_SEED,
        "total": len(configs),
        "task_ids": [c["task_id"] for c in configs],
        "stats": {
            "by_dim": _count(configs, lambda c: c["coordination_dim"]),
            "by_agent_count": _count(configs, lambda c: str(c["agent_count"])),
            "by_cell": _count(configs, lambda c: f"{c['task_family']}_{c['coordination_dim']}"),
            "by_task_type": _count(configs, lambda c: c["provenance"]["template"]),
        },
    }


def _count(configs: list[dict[str, Any]], key: Any) -> dict[str, int]:
    return dict(sorted(Counter(key(c) for c in configs).items()))


def config_path(config: dict[str, Any]) -> str:
    """Where a config lies in its suite's folder: `<cell>/<task_id>.json`."""
    return f"{config['task_family']}_{config['coordination_dim']}/{config['task_id']}.json"


def suite_files(name: str, suites: dict[str, list[dict[str, Any]]]) -> dict[str, str]:
    """Relative path -> file text for one suite's folder."""
    files = {config_path(c): dumps(c) for c in suites[name]}
    if name == FULL:
        files[SUBSET_FILE] = dumps(subset_document(suites[SUBSET]))
    return dict(sorted(files.items()))


def write_suite(root: Path, name: str, files: dict[str, str]) -> Path:
    """Replace `root/name` with exactly these files (written aside, then swapped in)."""
    root.mkdir(parents=True, exist_ok=True)
    target = root / name
    staging = Path(tempfile.mkdtemp(prefix=f".{name}-", dir=root))
    try:
        for rel, text in files.items():
            path = staging / rel
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(text.encode("utf-8"))
        if target.exists():
            shutil.rmtree(target)
        staging.rename(target)
    finally:
        if staging.exists():
            shutil.rmtree(staging)
    return target


def compare_suite(root: Path, name: str, files: dict[str, str]) -> list[str]:
    """Differences between `root/name` on disk and the expected files (empty: identical)."""
    folder = root / name
    on_disk = (
        {p.relative_to(folder).as_posix() for p in folder.rglob("*.json")}
        if folder.is_dir()
        else set()
    )
    problems = [f"{name}/{rel}: missing" for rel in sorted(files.keys() - on_disk)]
    problems += [f"{name}/{rel}: not generated" for rel in sorted(on_disk - files.keys())]
    for rel in sorted(files.keys() & on_disk):
        if (folder / rel).read_bytes() != files[rel].encode("utf-8"):
            problems.append(f"{name}/{rel}: differs")
    return problems
