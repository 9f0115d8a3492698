"""A strategy author's first hour (issue 26, item 1): the second example, written from
docs/planners.md alone, runs and is scored; the guide names every field a node reads and a
decision carries; a planner file imports the modules beside it; a node's exception names its
node, file, line and last frames (console and trajectory); `cocobench planners --check` ends
with a verdict and its exit code."""

from __future__ import annotations

import json
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from cocobench_agents.cli import main
from cocobench_agents.graphs import PlannerState
from cocobench_agents.harness.planner_check import CHECK_TASK
from tests.planners.test_plugins import DEMO, FIXTURE, results

pytestmark = pytest.mark.usefixtures("fresh_planners")

ROOT = Path(__file__).resolve().parents[2]
GUIDE = ROOT / "docs" / "planners.md"
FIRST_COME = f"{ROOT / 'examples' / 'strategies' / 'first_come.py'}:FIRST_COME"
THREE_AGENTS = "C_D2__DemoBedroom1__3agent_seed0"


def trajectory(out: Path, row: dict) -> dict:
    return json.loads((out / row["trajectory"]).read_text())


def line_of(path: Path, text: str) -> int:
    """The number of the line of `path` that contains `text`."""
    return next(n for n, line in enumerate(path.read_text().splitlines(), 1) if text in line)


def section(title: str) -> str:
    """The text of one `###` section of the guide."""
    return GUIDE.read_text().split(f"### {title}", 1)[1].split("\n### ", 1)[0]


def first_column(table_text: str) -> set[str]:
    """The backticked names in the first column of a Markdown table."""
    rows = [line for line in table_text.splitlines() if line.startswith("| `")]
    return {name for row in rows for name in re.findall(r"`([a-z_]+)`", row.split(" | ")[0])}


# -- the guide and the example written from it ----------------------------------------------


@pytest.mark.slow
def test_the_example_written_from_the_guide_runs_and_is_scored(tmp_path):
    out = tmp_path / "run"
    assert main(["run", "--planner", FIRST_COME, *DEMO, "--out", str(out)]) == 0
    rows = results(out)
    assert len(rows) == 4
    for row in rows:
        assert row["condition"] == "FC_image" and "infra_error" not in row
        assert row["terminal_reason"] == "max_steps"
        assert row["construct_status"] in ("scored", "not_engaged", "low_signal")
        assert 0 <= row["task_progress"] <= 1
    # Greedy robots choose the same object: the later one in team order idles, as documented.
    taken = [d for row in rows for d in trajectory(out, row)["planner_decisions"]
             if d["status"] == "taken"]
    assert taken, "greedy robots never chose the same object"
    for decision in taken:
        assert decision["parsed_call"] is None and decision["terminal_reason"] is None
        assert decision["taken_by"] != decision["agent"] and decision["wanted_call"]
    scored = [r for r in rows if r["construct_status"] == "scored"]
    assert scored and all(0 <= r["construct_score"] <= 1 for r in scored)


def test_the_guide_names_every_field_a_decision_carries(tmp_path):
    out = tmp_path / "run"
    assert main(["run", "--planner", "decentralized-broadcast", *DEMO, "--limit", "1",
                 "--out", str(out)]) == 0
    (row,) = results(out)
    decisions = trajectory(out, row)["planner_decisions"]
    # What decide returns: record() adds the running counts, which the guide names apart.
    counters = {"planner_steps", "parse_errors", "backend_errors"}
    fields = {key for d in decisions for key in d} - counters
    documented = first_column(section("Decisions"))
    assert fields <= documented, f"undocumented: {sorted(fields - documented)}"
    text = section("Decisions")
    assert all(f"`{name}`" in text for name in counters)
    for status in ("action", "done", "parse_error", "invalid_action_id", "backend_error",
                   "no_actions"):
        assert f"`{status}`" in text


def test_the_guide_names_every_state_key_and_the_boards_entry():
    assert first_column(section("What a node reads")) == set(PlannerState.__annotations__)
    board = section("The message board")
    assert '{"round": 3, "agent": "agent_2",' in board and "broadcast=True" in board


# -- modules beside the planner file -----------------------------------------------------------


SIBLING = textwrap.dedent("""
    from lab_sibling_helpers import build

    def build_with_helper():
        \"\"\"Built by a module beside this file.\"\"\"
        return build()
""")


@pytest.fixture
def sibling(strategy: Path, monkeypatch) -> Path:
    """A planner file importing a module of its own folder (not on sys.path)."""
    helpers = strategy.with_name("lab_sibling_helpers.py")
    helpers.write_text(FIXTURE.read_text() + "\nbuild = build_one_node\n")
    planner = strategy.with_name("with_helper.py")
    planner.write_text(SIBLING)
    monkeypatch.setattr(sys, "path", list(sys.path))  # restored after the test
    monkeypatch.delitem(sys.modules, "lab_sibling_helpers", raising=False)
    yield planner
    sys.modules.pop("lab_sibling_helpers", None)


@pytest.mark.slow
def test_a_planner_file_imports_the_modules_beside_it_in_worker_processes(sibling, tmp_path):
    assert str(sibling.parent) not in sys.path
    out = tmp_path / "run"
    assert main(["run", "--planner", f"{sibling}:build_with_helper", *DEMO, "--workers", "2",
                 "--jobs", "2", "--out", str(out)]) == 0
    rows = results(out)
    assert len(rows) == 4 and all("infra_error" not in r for r in rows)


@pytest.mark.slow
def test_a_fresh_process_imports_the_modules_beside_the_planner_file(sibling):
    # What a spawned or Ray worker does: only the reference string, a folder not on sys.path.
    probe = textwrap.dedent(f"""
        import asyncio
        from benchmark_adapter.tasks import load_tasks
        from cocobench_agents.episode_runner import EpisodeSpec, run_episode
        from cocobench_agents.models import ModelPool
        spec = EpisodeSpec(load_tasks("demo")[0], planner={f"{sibling}:build_with_helper"!r},
                           obs_mode="blind")
        print(asyncio.run(run_episode(spec, ModelPool()))[1].terminal_reason)
    """)
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                          timeout=120, cwd=ROOT)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["max_steps"]


def test_a_missing_sibling_module_is_a_one_line_error_naming_the_file(sibling, tmp_path,
                                                                      capsys):
    sibling.with_name("lab_sibling_helpers.py").unlink()
    assert main(["run", "--planner", f"{sibling}:build_with_helper", *DEMO,
                 "--out", str(tmp_path / "run")]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (f"cocobench: error: planner file {sibling}: importing it failed: "
                   "ModuleNotFoundError: No module named 'lab_sibling_helpers'")


# -- a node that raises --------------------------------------------------------------------------


def test_a_node_raising_in_the_check_names_node_file_line_and_frames(strategy, tmp_path,
                                                                     capsys):
    out = tmp_path / "run"
    assert main(["run", "--planner", f"{strategy}:build_crashes", *DEMO,
                 "--out", str(out)]) == 2
    err = capsys.readouterr().err
    first, *frames = err.strip().splitlines()
    raised = line_of(strategy, 'raise KeyError("agent_9")')
    assert first == (f"cocobench: error: planner {strategy}:build_crashes: its check episode "
                     f"({CHECK_TASK}, greedy) failed: KeyError: 'agent_9' in node 'crash' "
                     f"({strategy}, line {raised})")
    assert frames == [f'  File "{strategy}", line {raised}, in crash',
                      '    raise KeyError("agent_9")']
    assert "Traceback" not in err and "langgraph" not in err
    assert not out.exists()


@pytest.mark.slow
def test_a_node_raising_mid_run_is_told_on_the_console_and_in_the_trajectory(strategy,
                                                                              tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["run", "--planner", f"{strategy}:build_crashes_on_three", *DEMO,
                 "--out", str(out)]) == 1  # the run ends, with an error among its episodes
    failed = [r for r in results(out) if r.get("planner_error")]
    assert [r["task_id"] for r in failed] == [THREE_AGENTS]
    assert not any(r.get("infra_error") for r in results(out))
    raised = line_of(strategy, "return seats[agent]")
    called = line_of(strategy, "[seat_of(agent) for agent")
    headline = (f"KeyError: 'agent_3' in node 'seated_step' ({strategy}, line {raised})")
    error = failed[0]["planner_error"].splitlines()
    assert error[0] == headline
    frames = [line for line in error[1:] if line.startswith("  File ")]
    assert frames == [f'  File "{strategy}", line {called}, in seated_step',
                      f'  File "{strategy}", line {called}, in <listcomp>',
                      f'  File "{strategy}", line {raised}, in seat_of']
    console = capsys.readouterr().err
    assert f"{THREE_AGENTS}: PLANNER ERROR {headline}\n" + "\n".join(error[1:]) in console
    # The trajectory runs up to the exception, then a stop decision says the same.
    document = trajectory(out, failed[0])
    stop = document["trajectory"][-1]
    assert stop["label"] == "policy_stop"
    decision = stop["policy_decision"]
    assert (decision["status"], decision["terminal_reason"]) == ("planner_error",) * 2
    assert (decision["node"], decision["file"], decision["line"]) == \
        ("seated_step", str(strategy), raised)
    assert decision["error"] == headline and decision["traceback"] == error[1:]


# -- planners --check ----------------------------------------------------------------------------


def test_check_ends_with_a_passed_line_and_exit_0(strategy, capsys):
    assert main(["planners", f"{strategy}:build_one_node", "--check"]) == 0
    out = capsys.readouterr().out.strip().splitlines()
    assert out[-1].startswith("check passed: ")
    assert out[-1].endswith(f"{strategy}:build_one_node")


def test_check_ends_with_a_failed_line_and_exit_1(strategy, capsys):
    refs = [f"{strategy}:build_one_node", f"{strategy}:build_crashes"]
    assert main(["planners", *refs, "--check"]) == 1
    captured = capsys.readouterr()
    verdict = captured.out.strip().splitlines()[-1]
    assert re.fullmatch(rf"check FAILED: 1 of \d+ planner\(s\) not built in: "
                        rf"{re.escape(refs[1])}", verdict)
    assert (f"cocobench: check failed: planner {refs[1]}: its check episode "
            f"({CHECK_TASK}, greedy) failed: KeyError: 'agent_9' in node 'crash'"
            ) in captured.err
    assert "build_crashes" in captured.out  # the table still lists every planner


def test_check_with_json_keeps_stdout_json_and_gives_the_verdict_on_stderr(strategy,
                                                                           capsys):
    assert main(["planners", f"{strategy}:build_crashes", "--check", "--json"]) == 1
    captured = capsys.readouterr()
    listed = {p["name"] for p in json.loads(captured.out)}
    assert f"{strategy}:build_crashes" in listed
    assert captured.err.strip().splitlines()[-1].startswith("check FAILED: 1 of ")


def test_check_counts_a_package_that_does_not_load_as_failing(tmp_path, monkeypatch, capsys):
    site = tmp_path / "site"
    info = site / "torch_plugin-1.0.dist-info"
    info.mkdir(parents=True)
    (site / "torch_plugin.py").write_text("raise ImportError('No module named torch')\n")
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: torch-plugin\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text("[cocobench.planners]\nneeds-torch = "
                                           "torch_plugin:SPEC\n")
    monkeypatch.syspath_prepend(str(site))
    monkeypatch.delitem(sys.modules, "torch_plugin", raising=False)
    assert main(["planners", "--check"]) == 1
    captured = capsys.readouterr()
    assert captured.out.strip().splitlines()[-1].endswith(": needs-torch")
    assert "ImportError: No module named torch" in captured.err


SEALED_BID = f"{ROOT / 'examples' / 'strategies' / 'sealed_bid.py'}:SEALED_BID"


@pytest.mark.parametrize("planner", [FIRST_COME, SEALED_BID], ids=["first-come", "sealed-bid"])
def test_an_example_strategy_declares_its_round_and_plays_it_as_its_graph(planner,
                                                                            monkeypatch):
    """Its graph is built from its declared round, and an episode awaiting the round's
    functions directly is the episode its graph plays (robots contending, on 3 agents)."""
    from benchmark_adapter.tasks import load_tasks
    from cocobench_agents.episode_runner import EpisodeSpec
    from cocobench_agents.graphs import compiled_graph, planner_rounds
    from tests.planners.test_rounds import comparable, play

    rounds = planner_rounds(planner)
    assert rounds is not None
    assert list(compiled_graph(planner).builder.nodes) == [s.name for s in rounds.steps]
    config = next(c for c in load_tasks("demo") if len(c.agent_ids) == 3)
    spec = EpisodeSpec(config, planner=planner, obs_mode="blind", max_steps=30,
                       models={"*": "random:5", "agent_1": "random:9"})
    (direct, _), (graph, _) = (play(spec, path, monkeypatch) for path in ("rounds", "graph"))
    assert comparable(direct) == comparable(graph)
    assert {d["status"] for d in direct["planner_decisions"]} & {"taken", "outbid"}
