"""A strategy's own bugs are `planner_error`s (issue 36, item 4): a node that raises, a node
that returns a malformed decision record, and a graph that never ends each end their episode
as a planner error naming the strategy's node, file and line (never the framework's node that
would trip on the record later, never LangGraph's bare recursion error), with a trajectory;
they are counted apart from infrastructure errors in the summary, the report and the viewer;
the rest of the run is unaffected; and nothing suggests `--retry-errors` for them."""

from __future__ import annotations

import asyncio
import json

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from benchmark_adapter.tasks import load_tasks
from cocobench_agents.cli import main
from cocobench_agents.episode_runner import EpisodeSpec, run_episode
from cocobench_agents.graphs.node_errors import (
    PlannerNodeError,
    decision_problem,
    update_problem,
)
from cocobench_agents.models import ModelPool
from cocobench_agents.runfolder.summary import PLANNER_ERRORS, summary_table
from cocobench_agents.viewer.rows import error_label
from tests.planners.test_plugins import DEMO, results
from tests.planners.test_strategy_authoring import THREE_AGENTS, line_of, trajectory

pytestmark = pytest.mark.usefixtures("fresh_planners")

#: Each bug: the build function, the node the error names, and the text of the line it names
#: in the strategy's file.
BUGS = {
    "raises": ("build_crashes_on_three", "seated_step", "return seats[agent]"),
    "malformed record": ("build_malformed_on_three", "bid", "async def bid_without_status"),
    "endless loop": ("build_endless_on_three", "stall_with_three",
                     "async def stall_with_three"),
}
#: What each bug's headline says besides the node, file and line.
SAYS = {
    "raises": "KeyError: 'agent_3'",
    "malformed record": "MalformedUpdate: pending[2] has no 'status'",
    "endless loop": "GraphRecursionError: the graph ran",
}


def three_agents() -> EpisodeSpec:
    config = next(t for t in load_tasks("demo") if t.task_id == THREE_AGENTS)
    return EpisodeSpec(config, models={"*": "greedy"}, obs_mode="blind")


@pytest.mark.parametrize("bug", BUGS)
def test_each_bug_ends_the_episode_naming_the_strategys_node_file_and_line(strategy, bug,
                                                                          tmp_path):
    build, node, text = BUGS[bug]
    spec = three_agents()
    spec = EpisodeSpec(spec.config, planner=f"{strategy}:{build}", models=spec.models,
                       obs_mode=spec.obs_mode)
    path = tmp_path / "trajectory.json"
    with pytest.raises(PlannerNodeError) as raised:
        asyncio.run(run_episode(spec, ModelPool(), trajectory_path=path))
    failure = raised.value.failure
    line = line_of(strategy, text)
    assert (failure.node, failure.file, failure.line) == (node, str(strategy), line)
    assert failure.headline().startswith(SAYS[bug])
    assert failure.headline().endswith(f"in node {node!r} ({strategy}, line {line})")
    assert "cocobench_agents" not in failure.describe()  # not the framework's node or file
    # The trajectory up to there is written, its stop decision saying the same.
    stop = json.loads(path.read_text())["trajectory"][-1]["policy_decision"]
    assert (stop["status"], stop["node"], stop["line"]) == ("planner_error", node, line)
    assert stop["error"] == failure.headline()


def test_an_endless_loop_names_its_last_nodes(strategy):
    spec = three_agents()
    spec = EpisodeSpec(spec.config, planner=f"{strategy}:build_endless_on_three",
                       models=spec.models, obs_mode=spec.obs_mode)
    with pytest.raises(PlannerNodeError) as raised:
        asyncio.run(run_episode(spec, ModelPool()))
    limit = 6 * spec.budget + 50
    assert (f"the graph ran {limit} supersteps without ending (the last nodes: "
            "stall_with_three -> stall_with_three -> stall_with_three -> stall_with_three)"
            ) in raised.value.failure.error


@pytest.mark.slow
@pytest.mark.parametrize("bug", BUGS)
def test_a_bug_mid_run_is_a_planner_error_counted_apart_and_never_retried(strategy, bug,
                                                                          tmp_path, capsys):
    build, node, text = BUGS[bug]
    out = tmp_path / "run"
    assert main(["run", "--planner", f"{strategy}:{build}", *DEMO, "--out", str(out)]) == 1
    rows = results(out)
    assert len(rows) == 4 and not any("infra_error" in r for r in rows)
    (failed,) = [r for r in rows if r.get("planner_error")]
    line = line_of(strategy, text)
    assert failed["task_id"] == THREE_AGENTS and failed["task_success"] == 0
    assert failed["planner_error"].splitlines()[0].endswith(
        f"in node {node!r} ({strategy}, line {line})")
    stop = trajectory(out, failed)["trajectory"][-1]["policy_decision"]
    assert (stop["status"], stop["file"], stop["line"]) == ("planner_error", str(strategy), line)
    # The rest of the run is unaffected: every other episode ran to its budget.
    assert {r["terminal_reason"] for r in rows if r is not failed} == {"max_steps"}
    # Told apart, with no retry advice: the console, the summary, the viewer, the report.
    err = capsys.readouterr().err
    assert "PLANNER ERROR" in err and "1 episode ended on a planner error" in err
    assert "--retry-errors" not in err and "infrastructure" not in err
    headers, (summary,) = summary_table(rows)
    cells = dict(zip(headers, summary, strict=True))
    assert (cells["errors"], cells[PLANNER_ERRORS]) == (0, 1)
    assert error_label(failed).startswith(f"planner: {SAYS[bug]}")
    report = tmp_path / "report"
    assert main(["report", str(out), "--out", str(report)]) == 0
    text = "\n".join(p.read_text() for p in sorted(report.glob("*.md")))
    assert "1 of 4 episodes ended on a planner error" in text
    assert "retry-errors" not in text and "planner_error" in text  # the terminal states
    # --retry-errors runs infrastructure failures again, never a planner error.
    assert main(["run", "--planner", f"{strategy}:{build}", "--out", str(out), "--resume",
                 "--retry-errors"]) == 1
    assert len(results(out)) == 4


# -- the check of a node's update -----------------------------------------------------------


def test_a_decision_record_as_decide_makes_it_passes():
    record = {"agent": "agent_1", "status": "action", "parsed_call": "navigate(Apple)",
              "terminal_reason": None, "wanted_call": ["any", "JSON"]}
    assert decision_problem(record) is None
    assert update_problem({"pending": [record], "terminal_reason": None, "mine": 3}) is None
    assert update_problem(None) is None and update_problem({}) is None


@pytest.mark.parametrize(("update", "problem"), [
    ({"pending": [{"agent": "a", "parsed_call": None, "terminal_reason": None}]},
     "pending[0] has no 'status'"),
    ({"pending": [{"agent": "a", "status": 3, "parsed_call": None,
                   "terminal_reason": None}]}, "pending[0] has status=3, a int, not str"),
    ({"pending": {"agent": "a"}}, "'pending' is a dict, not a list of decision records"),
    ({"pending": ["navigate(Apple)"]}, "pending[0] is a str, not a decision record"),
    ({"terminal_reason": 1}, "'terminal_reason' is a int, not text or None"),
    ({"round_index": "2"}, "'round_index' is a str, not a whole number"),
    ("done", "it returned str 'done', not a dict of state updates"),
])
def test_a_malformed_update_is_named(update, problem):
    assert update_problem(update) is not None
    assert update_problem(update).startswith(problem)


json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=8),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(
        st.sampled_from(["pending", "status", "agent", "parsed_call", "terminal_reason",
                         "round_index", "x"]) | st.text(max_size=4), inner, max_size=5),
    max_leaves=20)


@settings(max_examples=300, deadline=None)
@given(json_values)
def test_any_update_a_strategy_returns_is_judged_without_raising(update):
    problem = update_problem(update)
    assert problem is None or (isinstance(problem, str) and problem)


def test_a_planner_error_line_is_a_valid_result_line(tmp_path):
    from cocobench_agents.runfolder.episode_key import EpisodeKey
    from cocobench_agents.runfolder.result_line import line_error, planner_error_line

    key = EpisodeKey("greedy", "C0_image", THREE_AGENTS)
    line = planner_error_line(key, "KeyError: 'x' in node 'n' (f.py, line 3)",
                              {"task_success": 0, "legal_plan": 0})
    assert line_error(line) is None
    assert line_error({**line, "planner_error": 3}) is not None


def test_the_summary_counts_planner_errors_apart_and_only_shows_them_when_there_are_some():
    base = {"model": "greedy", "condition": "C0_image", "task_success": 0, "legal_plan": 0}
    rows = [{**base, "task_id": "a", "infra_error": "timeout"},
            {**base, "task_id": "b", "planner_error": "KeyError: 'x' in node 'n'"},
            {**base, "task_id": "c", "legal_plan": 1, "construct_score": 0.5}]
    headers, (row,) = summary_table(rows)
    cells = dict(zip(headers, row, strict=True))
    assert (cells["episodes"], cells["errors"], cells[PLANNER_ERRORS]) == (3, 1, 1)
    assert cells["legal"] == "100.0%" and cells["CS"] == "0.50 (n=1)"  # the ran episode's
    assert PLANNER_ERRORS not in summary_table(rows[::2])[0]


WRONG_NAME = '''
from langgraph.graph import END, START, StateGraph
from langgraph.runtime import Runtime

from cocobench_agents.graphs import PlannerContext, PlannerState


async def step(state: PlannerState, rt: Runtime[PlannerContext]) -> dict:
    return {"terminal_reason": "done"}


def build_wrong_name() -> StateGraph:
    graph = StateGraph(PlannerState, context_schema=PlannerContext)
    graph.add_node("step", step)
    graph.add_edge(START, "step")
    graph.add_edge("step", END)
    return graph
'''


def test_a_node_parameter_langgraph_never_passes_is_refused_naming_file_and_line(tmp_path,
                                                                                capsys):
    strategy = tmp_path / "wrong_name.py"
    strategy.write_text(WRONG_NAME)
    out = tmp_path / "run"
    assert main(["run", "--planner", f"{strategy}:build_wrong_name", *DEMO,
                 "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (f"cocobench: error: planner {strategy}:build_wrong_name: building its graph "
                   f"failed: NodeSignatureError: node 'step' ({strategy}, line "
                   f"{line_of(strategy, 'async def step')}): its parameter 'rt' is not one "
                   "LangGraph passes; name it 'runtime' for the Runtime (runtime.context is "
                   "the PlannerContext)")
    assert not out.exists()


@pytest.mark.needs_inspect
@pytest.mark.slow
def test_inspect_scores_a_planner_error_as_a_failure_told_apart_never_a_sample_error(
        strategy, tmp_path):
    from inspect_ai import eval as inspect_eval

    from cocobench_agents.inspect_eval.scorer import PLANNER_ERROR
    from cocobench_agents.inspect_eval.solver import RESULT
    from cocobench_agents.inspect_eval.task import cocobench
    from tests.inspect_eval.conftest import REPLIES, scripted_mockllm

    [log] = inspect_eval(cocobench(suite="demo", planner=f"{strategy}:build_crashes_on_three",
                                   obs="blind"),
                         model=scripted_mockllm(REPLIES), log_dir=str(tmp_path / "logs"),
                         display="none")
    assert log.status == "success"  # no sample error: nothing for eval-retry to run again
    assert all(sample.error is None for sample in log.samples)
    scores = {s.store[RESULT]["task_id"]: s.scores["cocobench_scorer"] for s in log.samples}
    failed = scores.pop(THREE_AGENTS)
    assert failed.value[PLANNER_ERROR] == 1.0 and failed.value["success"] == 0.0
    assert failed.explanation.startswith("KeyError: 'agent_3' in node 'seated_step' "
                                         f"({strategy}, line ")
    assert {score.value[PLANNER_ERROR] for score in scores.values()} == {0.0}
    share = {score.name: score for score in log.results.scores}[PLANNER_ERROR]
    assert share.metrics["mean"].value == pytest.approx(1 / 4)  # 1 of the demo's 4


def test_evaluate_counts_a_planner_error_apart_and_warns_without_retry_advice(strategy,
                                                                             tmp_path):
    import warnings

    import cocobench_agents as cb

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        results = cb.evaluate("demo", models="greedy", max_steps=4, out=tmp_path / "r",
                              planners=[f"{strategy}:build_crashes_on_three"])
    assert (results.errors, results.planner_errors) == (0, 1)
    (told,) = [str(w.message) for w in caught if "planner error" in str(w.message)]
    assert "retry_errors" not in told and "fix the strategy" in told
