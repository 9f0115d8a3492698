"""Planners from the researcher's code: `--planner FILE.py:NAME` / `module:NAME`, packages
registering under `cocobench.planners`, the pre-run check, the record in run.json and the
resume guard, worker processes, and every way loading user code fails (exit 2, one line)."""

from __future__ import annotations

import hashlib
import json
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from cocobench_agents.cli import main
from cocobench_agents.graphs import planner_spec
from cocobench_agents.graphs.plugins import default_code, forget_user_planners

FIXTURE = Path(__file__).with_name("user_planner.py")
DEMO = ["--model", "greedy", "--suite", "demo"]


pytestmark = pytest.mark.usefixtures("fresh_planners")


def results(out: Path) -> list[dict]:
    return [json.loads(line) for line in (out / "results.jsonl").read_text().splitlines()]


def error_line(capsys) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    return lines[0]


# -- planners in files and modules -------------------------------------------------------------


def test_a_function_in_a_file_runs_with_the_documented_defaults(strategy, tmp_path,
                                                                 monkeypatch):
    monkeypatch.chdir(strategy.parent)  # a relative path, as typed
    out = tmp_path / "run"
    assert main(["run", "--planner", "mine.py:build_one_node", *DEMO, "--limit", "1",
                 "--out", str(out)]) == 0
    canonical = f"{strategy.resolve()}:build_one_node"
    (row,) = results(out)
    assert row["condition"] == "one-node_image"  # the code comes from the function's name
    assert row["planner"] == canonical and "infra_error" not in row
    assert row["terminal_reason"] and "task_success" in row
    spec = planner_spec(canonical)
    assert (spec.decentralized, spec.uses_models) == (False, True)
    assert spec.description == "A centralized planner in one node."
    recorded = json.loads((out / "run.json").read_text())["planners"][canonical]
    assert recorded == {"code": "one-node", "kind": "file", "source": canonical,
                        "file": str(strategy.resolve()),
                        "sha256": hashlib.sha256(strategy.read_bytes()).hexdigest(),
                        "broadcast": False, "prompt": "team"}


def test_a_planner_spec_keeps_its_code_and_policy_and_works_in_conditions(strategy, tmp_path):
    out = tmp_path / "run"
    assert main(["run", "--conditions", f"{strategy}:ONE_NODE_blind", *DEMO, "--limit", "1",
                 "--out", str(out)]) == 0
    (row,) = results(out)
    assert row["condition"] == "ON_blind" and row["obs_mode"] == "blind"
    spec = planner_spec(f"{strategy}:ONE_NODE")
    assert spec.name == f"{strategy}:ONE_NODE" and spec.retry_policy.max_attempts == 1


def test_a_module_planner_runs(strategy, tmp_path, monkeypatch):
    package = tmp_path / "labpkg"
    package.mkdir()
    (package / "__init__.py").write_text("")
    shutil.copy(strategy, package / "strategies.py")
    monkeypatch.syspath_prepend(str(tmp_path))
    for name in ("labpkg", "labpkg.strategies"):
        monkeypatch.delitem(sys.modules, name, raising=False)
    out = tmp_path / "run"
    assert main(["run", "--planner", "labpkg.strategies:ONE_NODE", *DEMO, "--limit", "1",
                 "--out", str(out)]) == 0
    (row,) = results(out)
    assert row["condition"] == "ON_image" and row["planner"] == "labpkg.strategies:ONE_NODE"
    recorded = json.loads((out / "run.json").read_text())["planners"]
    assert recorded["labpkg.strategies:ONE_NODE"]["kind"] == "module"
    assert recorded["labpkg.strategies:ONE_NODE"]["file"] == str(package / "strategies.py")


def test_the_documented_strategy_runs(tmp_path):
    guide = (Path(__file__).resolve().parents[2] / "docs" / "planners.md").read_text()
    section = guide.split("## Write it in your own file", 1)[1]
    code = section.split("```python\n", 1)[1].split("```", 1)[0]
    (tmp_path / "my_strategy.py").write_text(code)
    out = tmp_path / "run"
    assert main(["run", "--planner", f"{tmp_path / 'my_strategy.py'}:build_round_robin",
                 *DEMO, "--limit", "1", "--out", str(out)]) == 0
    (row,) = results(out)
    assert row["condition"] == "round-robin_image" and "infra_error" not in row


def test_default_codes_come_from_the_name():
    assert default_code("build_claim_board") == "claim-board"
    assert default_code("greedy_pairs") == "greedy-pairs"


# -- resume ------------------------------------------------------------------------------------


def test_resume_refuses_a_changed_planner_file_and_keeps_what_was_recorded(strategy, tmp_path,
                                                                          capsys):
    out = tmp_path / "run"
    ref = f"{strategy}:build_one_node"
    assert main(["run", "--planner", ref, *DEMO, "--limit", "2", "--out", str(out)]) == 0
    # A run folder never makes code run: the planner is named again to be loaded.
    assert main(["run", "--out", str(out), "--resume", "--planner", ref]) == 0  # unchanged
    kept = (out / "results.jsonl").read_bytes()
    strategy.write_text(strategy.read_text() + "\n# tuned the prompt order\n")
    forget_user_planners()  # as a new process would
    capsys.readouterr()
    assert main(["run", "--out", str(out), "--resume", "--retry-errors", "--planner",
                 ref]) == 2
    line = error_line(capsys)
    assert str(strategy) in line and "changed since the run was recorded" in line
    assert (out / "results.jsonl").read_bytes() == kept


# -- mistakes: loading -------------------------------------------------------------------------


@pytest.mark.parametrize(("ref", "expected"), [
    ("{dir}/missing.py:build", "{dir}/missing.py: No such file or directory"),
    ("{dir}/broken.py:build", "{dir}/broken.py, line 2:"),
    ("{dir}/raises.py:build", "{dir}/raises.py: importing it failed: ImportError: needs torch"),
    ("{file}:nope", "{file}:nope: 'nope' is not defined there"),
    ("{file}:NOT_A_PLANNER", "NOT_A_PLANNER is of type int, not a PlannerSpec or a function"),
    ("{file}:BAD_CODE", "condition code 'C0' is the built-in centralized's"),
    ("{file}:BAD_LOOP", "loop 'rounds' is not one of step, round, led-round"),
    ("{file}:BAD_SHAPE", "loop 'round' asks every agent, so its prompt is 'agent'"),
    ("{file}:BAD_CALLS", "calls_per_seat 0 must be a whole number of at least 1"),
    ("{file}", "unknown planner"),
    ("{file}:", "expected FILE.py:NAME or package.module:NAME"),
    ("no_such_lab.strategies:build", "planner module 'no_such_lab.strategies' not found"),
    ("no-such-planner", "unknown planner 'no-such-planner' (built in: centralized,"),
])
def test_user_code_that_does_not_load_is_one_line_exit_2(strategy, tmp_path, capsys, ref,
                                                          expected):
    (strategy.parent / "broken.py").write_text("def build():\n    return graph graph\n")
    (strategy.parent / "raises.py").write_text("raise ImportError('needs torch')\n")
    fill = {"dir": strategy.parent, "file": strategy}
    out = tmp_path / "run"
    assert main(["run", "--planner", ref.format(**fill), *DEMO, "--out", str(out)]) == 2
    assert expected.format(**fill) in error_line(capsys)
    assert not out.exists()


@pytest.mark.parametrize(("name", "expected"), [
    ("build_not_a_graph", "its build function returned a dict, not a langgraph StateGraph"),
    ("build_raises", "building its graph failed: RuntimeError: no graph today"),
    ("build_wrong_context", "declares context_schema=OtherContext"),
    ("build_never_ends", "did not end; end a step with observe_next"),
    ("build_no_terminal_reason", "ended without a recorded terminal reason"),
])
def test_the_check_stops_a_broken_graph_before_any_episode(strategy, tmp_path, capsys, name,
                                                           expected):
    out = tmp_path / "run"
    assert main(["run", "--planner", f"{strategy}:{name}", *DEMO, "--out", str(out)]) == 2
    line = error_line(capsys)
    assert line.startswith(f"cocobench: error: planner {strategy}:{name}: ")
    assert expected in line
    assert not out.exists()  # nothing written, no episode recorded as a crash


def test_unknown_conditions_still_name_the_choices(capsys, tmp_path):
    assert main(["run", "--conditions", "XX_image", *DEMO, "--out", str(tmp_path / "r")]) == 2
    assert "unknown condition 'XX_image'" in error_line(capsys)


def test_two_planners_with_one_code_are_refused(strategy, tmp_path, capsys):
    twin = strategy.with_name("twin.py")
    shutil.copy(strategy, twin)
    conditions = f"{strategy}:ONE_NODE_image,{twin}:ONE_NODE_image"
    assert main(["run", "--conditions", conditions, *DEMO, "--out", str(tmp_path / "r")]) == 2
    assert "share the condition ON_image" in error_line(capsys)


# -- installed packages (entry points) ---------------------------------------------------------


def _distribution(site: Path, name: str, entry_points: str) -> None:
    info = site / f"{name.replace('-', '_')}-1.0.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text(f"[cocobench.planners]\n{entry_points}\n")


@pytest.fixture
def site(tmp_path: Path, monkeypatch) -> Path:
    """Three installed packages: a working planner, one whose import fails, one taking a
    built-in name (as pip would lay them out: a module and its dist-info)."""
    site = tmp_path / "site"
    site.mkdir()
    shutil.copy(FIXTURE, site / "good_plugin.py")
    (site / "torch_plugin.py").write_text("raise ImportError('No module named torch')\n")
    _distribution(site, "good-plugin", "one-node-plugin = good_plugin:ONE_NODE")
    _distribution(site, "torch-plugin", "needs-torch = torch_plugin:SPEC")
    _distribution(site, "greedy-plugin", "centralized = good_plugin:build_one_node")
    monkeypatch.syspath_prepend(str(site))
    for name in ("good_plugin", "torch_plugin"):
        monkeypatch.delitem(sys.modules, name, raising=False)
    return site


def test_planners_lists_every_planner_and_where_it_comes_from(site, capsys):
    assert main(["planners", "--json"]) == 0
    planners = json.loads(capsys.readouterr().out)
    listed = {p["name"]: p for p in planners if p.get("distribution") != "greedy-plugin 1.0"}
    builtin, taken = (p for p in planners if p["name"] == "centralized")
    assert builtin["kind"] == "built-in" and builtin["code"] == "C0"
    assert taken["distribution"] == "greedy-plugin 1.0"
    assert "the name is taken by a built-in planner" in taken["error"]
    assert listed["leader-worker"]["source"] == \
        "cocobench_agents.graphs.leader_worker:build_leader_worker"
    good = listed["one-node-plugin"]
    assert (good["kind"], good["code"], good["distribution"]) == \
        ("entry point", "ON", "good-plugin 1.0")
    assert good["file"] == str(site / "good_plugin.py") and good["models"] == "one for the team"
    assert "ImportError: No module named torch" in listed["needs-torch"]["error"]
    assert "torch-plugin 1.0" in listed["needs-torch"]["error"]


def test_the_table_marks_a_broken_package_without_failing(site, capsys):
    assert main(["planners"]) == 0
    table = capsys.readouterr().out
    row = next(line for line in table.splitlines() if line.startswith("needs-torch"))
    assert "BROKEN: planner 'needs-torch' (entry point torch_plugin:SPEC" in row
    assert any(line.startswith("one-node-plugin") for line in table.splitlines())


def test_an_installed_planner_runs_by_name_and_by_code(site, tmp_path):
    out = tmp_path / "run"
    assert main(["run", "--conditions", "ON_blind,C0_blind", *DEMO, "--limit", "1",
                 "--out", str(out)]) == 0
    rows = {r["condition"]: r for r in results(out)}
    assert set(rows) == {"ON_blind", "C0_blind"}
    assert rows["ON_blind"]["planner"] == "one-node-plugin"
    recorded = json.loads((out / "run.json").read_text())["planners"]
    assert recorded["one-node-plugin"]["distribution"] == "good-plugin 1.0"
    assert "centralized" not in recorded  # built-ins are the package version's


def test_a_broken_package_does_not_break_runs_that_do_not_use_it(site, tmp_path, capsys):
    assert main(["run", "--planner", "centralized", *DEMO, "--limit", "1",
                 "--out", str(tmp_path / "ok")]) == 0
    capsys.readouterr()
    out = tmp_path / "broken"
    assert main(["run", "--planner", "needs-torch", *DEMO, "--out", str(out)]) == 2
    line = error_line(capsys)
    assert "entry point torch_plugin:SPEC of torch-plugin 1.0" in line
    assert "ImportError: No module named torch" in line and not out.exists()


# -- other processes ---------------------------------------------------------------------------


@pytest.mark.slow
def test_worker_processes_run_a_file_planner(strategy, tmp_path):
    out = tmp_path / "run"
    assert main(["run", "--planner", f"{strategy}:build_one_node", *DEMO, "--workers", "2",
                 "--jobs", "2", "--out", str(out)]) == 0
    rows = results(out)
    assert len(rows) == 4 and all("infra_error" not in r for r in rows)
    assert {r["planner"] for r in rows} == {f"{strategy}:build_one_node"}


@pytest.mark.slow
def test_a_fresh_process_resolves_the_planner_from_its_string(strategy):
    # What a spawned or Ray worker does: nothing inherited, only the episode spec's string.
    probe = textwrap.dedent(f"""
        import asyncio
        from benchmark_adapter.tasks import load_tasks
        from cocobench_agents.episode_runner import EpisodeSpec, run_episode
        from cocobench_agents.models import ModelPool
        config = load_tasks("demo")[0]
        spec = EpisodeSpec(config, planner={f"{strategy}:ONE_NODE"!r}, obs_mode="blind")
        _, result = asyncio.run(run_episode(spec, ModelPool()))
        print(result.terminal_reason, result.planner)
    """)
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                          timeout=120, check=True)
    reason, planner = done.stdout.split()
    assert reason == "max_steps" and planner == f"{strategy}:ONE_NODE"


def test_a_name_two_packages_register_is_broken_for_both(tmp_path, monkeypatch, capsys):
    site = tmp_path / "site"
    site.mkdir()
    shutil.copy(FIXTURE, site / "twin_plugin.py")
    _distribution(site, "twin-a", "twin = twin_plugin:ONE_NODE")
    _distribution(site, "twin-b", "twin = twin_plugin:build_one_node")
    monkeypatch.syspath_prepend(str(site))
    assert main(["planners", "--json"]) == 0
    twins = [p for p in json.loads(capsys.readouterr().out) if p["name"] == "twin"]
    assert {p["distribution"] for p in twins} == {"twin-a 1.0", "twin-b 1.0"}
    assert all("registered by several packages" in p["error"] for p in twins)
    assert main(["run", "--planner", "twin", *DEMO, "--out", str(tmp_path / "r")]) == 2
    assert "registered by several packages" in error_line(capsys)


def test_resume_refuses_another_version_of_an_installed_planner(site, tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["run", "--planner", "one-node-plugin", *DEMO, "--limit", "1",
                 "--out", str(out)]) == 0
    info = site / "good_plugin-1.0.dist-info"
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: good-plugin\nVersion: 2.0\n")
    info.rename(site / "good_plugin-2.0.dist-info")
    forget_user_planners()
    capsys.readouterr()
    assert main(["run", "--out", str(out), "--resume"]) == 2
    line = error_line(capsys)
    assert "now comes from good-plugin 2.0" in line and "recorded with good-plugin 1.0" in line
