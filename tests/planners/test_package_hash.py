"""A packaged strategy is guarded whole (issue 36, item 7): with `lazy_builder`, the logic
lives in modules the spec's own module never imports, so `--resume` hashes every .py file of
the package, not its `__init__.py` alone; and `planners FILE --check` checks the files named,
not every installed plugin."""

from __future__ import annotations

import hashlib
import json
import shutil
import sys
from pathlib import Path

import pytest

from cocobench_agents.cli import main
from cocobench_agents.graphs.plugins import forget_user_planners
from tests.planners.test_plugins import DEMO, FIXTURE, _distribution, error_line, results

pytestmark = pytest.mark.usefixtures("fresh_planners")

PACKAGE = "lab_lazy_plugin"
SPEC = f"""
from cocobench_agents.graphs import PlannerSpec, lazy_builder

SPEC = PlannerSpec("lab-lazy", "LAZY", lazy_builder("{PACKAGE}.graph:build_one_node"),
                   False, True, "one node, its graph named by a string")
"""


@pytest.fixture
def package(tmp_path: Path, monkeypatch) -> Path:
    """An installed package whose spec names its graph with lazy_builder (graph.py)."""
    site = tmp_path / "site"
    folder = site / PACKAGE
    folder.mkdir(parents=True)
    (folder / "__init__.py").write_text(SPEC)
    shutil.copy(FIXTURE, folder / "graph.py")
    _distribution(site, "lab-lazy-plugin", f"lab-lazy = {PACKAGE}:SPEC")
    monkeypatch.syspath_prepend(str(site))
    yield folder
    for name in (PACKAGE, f"{PACKAGE}.graph"):
        sys.modules.pop(name, None)


def test_resume_refuses_a_package_whose_graph_module_changed(package, tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["run", "--planner", "lab-lazy", *DEMO, "--limit", "1", "--out", str(out)]) == 0
    recorded = json.loads((out / "run.json").read_text())["planners"]["lab-lazy"]
    assert recorded["package"] == str(package)
    assert recorded["file"] == str(package / "__init__.py")
    assert main(["run", "--out", str(out), "--resume"]) == 0  # unchanged
    kept = (out / "results.jsonl").read_bytes()
    graph = package / "graph.py"
    graph.write_text(graph.read_text().replace("policy=\"one_node\"", "policy=\"tuned\""))
    forget_user_planners()  # as a new process would
    capsys.readouterr()
    assert main(["run", "--out", str(out), "--resume"]) == 2
    assert error_line(capsys) == (
        f"cocobench: error: --resume: planner package {package} changed since the run was "
        "recorded; restore it, or start a new run in another --out")
    assert (out / "results.jsonl").read_bytes() == kept


def test_a_run_recorded_with_the_init_files_hash_still_resumes(package, tmp_path):
    out = tmp_path / "run"
    assert main(["run", "--planner", "lab-lazy", *DEMO, "--limit", "1", "--out", str(out)]) == 0
    record = json.loads((out / "run.json").read_text())
    then = record["planners"]["lab-lazy"]
    del then["package"]  # as a run recorded before packages were hashed whole
    then["sha256"] = hashlib.sha256((package / "__init__.py").read_bytes()).hexdigest()
    (out / "run.json").write_text(json.dumps(record))
    forget_user_planners()
    assert main(["run", "--out", str(out), "--resume"]) == 0
    assert len(results(out)) == 1


def test_check_of_a_named_file_leaves_the_installed_plugins_alone(package, strategy, capsys):
    (package / "__init__.py").write_text("raise ImportError('No module named torch')\n")
    ref = f"{strategy}:build_one_node"
    assert main(["planners", ref, "--check"]) == 0
    captured = capsys.readouterr()
    assert captured.out.strip().splitlines()[-1] == (
        f"check passed: 1 planner(s) not built in compile and end their greedy demo "
        f"episode: {ref}")
    assert "torch" not in captured.err
    assert "lab-lazy" in captured.out  # still listed, as broken
    assert main(["planners", "--check"]) == 1  # none named: the installed ones are checked
    assert "No module named torch" in capsys.readouterr().err
