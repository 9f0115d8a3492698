"""A built-in planner's round is declared once, as plain async functions (`graphs/rounds.py`):
its LangGraph graph is built from those functions, and an episode awaits them in a plain loop
(`play_rounds`) instead of running the graph. The loop must play exactly as the graph plays:
the same trajectory, decisions, message board and terminal reason for every built-in planner,
and a strategy's failure (a node raising, in a node or a fan-out's branch; a malformed update;
a round that never ends) told with the same node, file, line and words."""

from __future__ import annotations

import asyncio
import textwrap
from pathlib import Path

import pytest

from benchmark_adapter.tasks import load_tasks
from cocobench_agents import episode_runner
from cocobench_agents.episode_runner import EpisodeSpec, run_episode
from cocobench_agents.graphs import PLANNERS, compiled_graph, planner_rounds
from cocobench_agents.graphs.node_errors import PlannerNodeError
from cocobench_agents.graphs.rounds import FanOut, Node, Rounds
from cocobench_agents.models import ModelPool
from tests.envs.test_equality import _strip

pytestmark = pytest.mark.usefixtures("fresh_planners")

#: The two ways an episode can play a planner that declares its rounds.
PATHS = ("rounds", "graph")
#: Differ between any two runs of the same episode.
TIMES = {"elapsed_s", "started_at", "finished_at"}


def play(spec: EpisodeSpec, path: str, monkeypatch, **kwargs):
    """Run `spec` through the plain loop, or through LangGraph (the runner then finds no
    declared rounds, as for a strategy that gives only a graph)."""
    with monkeypatch.context() as patch:
        if path == "graph":
            patch.setattr(episode_runner, "planner_rounds", lambda name: None)
        return asyncio.run(run_episode(spec, ModelPool(), **kwargs))


def comparable(document: dict) -> dict:
    return _strip({k: v for k, v in document.items() if k not in TIMES})


def specs() -> list[EpisodeSpec]:
    """Every built-in planner on demo instances of two to four agents, with models that
    choose differently each step (random, seeded per agent) and with greedy."""
    configs = load_tasks("demo")
    return [EpisodeSpec(config, planner=planner, obs_mode="blind", models=models,
                        max_steps=30)
            for planner in PLANNERS for config in configs
            for models in ({"*": "greedy"}, {"*": "random:5", "agent_1": "random:9"})]


@pytest.mark.parametrize("planner", PLANNERS)
def test_the_plain_loop_plays_every_episode_as_the_graph_does(planner, monkeypatch):
    cases = [s for s in specs() if s.planner == planner]
    reasons = set()
    for spec in cases:
        direct, direct_result = play(spec, "rounds", monkeypatch)
        graph, graph_result = play(spec, "graph", monkeypatch)
        assert comparable(direct) == comparable(graph), (spec.config.task_id, spec.models)
        assert _strip(direct_result.model_dump(exclude={"elapsed_s"})) == \
            _strip(graph_result.model_dump(exclude={"elapsed_s"}))
        reasons.add(direct_result.terminal_reason)
    assert len(cases) >= 8 and reasons  # several instances, seats and models compared


def test_each_built_in_graph_is_built_from_its_declared_rounds():
    """One home for each planner's loop: the graph's nodes are the round's functions."""
    for name, spec in PLANNERS.items():
        rounds = planner_rounds(name)
        assert spec.rounds is not None and isinstance(rounds, Rounds), name
        nodes = compiled_graph(name).builder.nodes
        assert list(nodes) == [step.name for step in rounds.steps], name
        for step in rounds.steps:
            runnable = nodes[step.name].runnable
            function = getattr(runnable, "afunc", None) or runnable.func
            assert function.__code__ is step.run.__code__, (name, step.name)


STRATEGY = textwrap.dedent('''
    """Strategies that declare their rounds, each with a bug on the third step."""
    from cocobench_agents.graphs import PlannerSpec, land_round
    from cocobench_agents.graphs.centralized import act, choose
    from cocobench_agents.graphs.decentralized import board_branches, make_decide_agent
    from cocobench_agents.graphs.rounds import FanOut, Node, Rounds

    decide_agent = make_decide_agent(broadcast=False)


    async def choose_until_three(state, runtime):
        if runtime.context.tools.step_index >= 3:
            return {"pending": [state["no such key"]]}
        return await choose(state, runtime)


    async def decide_until_three(branch, runtime):
        if runtime.context.tools.step_index >= 3 and branch["agent"] == "agent_1":
            raise RuntimeError("agent_1 cannot decide")
        return await decide_agent(branch, runtime)


    async def malformed_on_three(state, runtime):
        if runtime.context.tools.step_index >= 3:
            return {"pending": [{"agent": None, "parsed_call": None}]}
        return await choose(state, runtime)


    async def stall(state, runtime):
        return {"round_index": state.get("round_index", 0) + 1}


    def spec(name, *steps, loop="step"):
        rounds = lambda: Rounds(steps)
        return PlannerSpec(name, name.upper(), lambda: rounds().graph(),
                           decentralized=loop == "round", uses_models=True,
                           description=name, loop=loop, rounds=rounds)


    CRASHES = spec("crashes", Node("pick", choose_until_three), Node("act", act))
    BRANCH_CRASHES = spec("branch-crashes",
                          FanOut("decide_agent", board_branches, decide_until_three),
                          Node("land_round", land_round), loop="round")
    MALFORMED = spec("malformed", Node("pick", malformed_on_three), Node("act", act))
    ENDLESS = spec("endless", Node("stall", stall))
''')

#: Each bug: the spec, the node the error names, the start of its headline and the text of
#: the line it names.
BUGS = {
    "node raises": ("CRASHES", "pick", "KeyError: 'no such key'",
                    'return {"pending": [state["no such key"]]}'),
    "branch raises": ("BRANCH_CRASHES", "decide_agent", "RuntimeError: agent_1 cannot decide",
                      'raise RuntimeError("agent_1 cannot decide")'),
    "malformed update": ("MALFORMED", "pick", "MalformedUpdate: pending[0] has no 'status'",
                         "async def malformed_on_three"),
    "endless": ("ENDLESS", "stall", "GraphRecursionError: the graph ran 230 supersteps "
                "without ending (the last nodes: stall -> stall -> stall -> stall)",
                "async def stall"),
}


@pytest.fixture
def declared(tmp_path: Path) -> Path:
    path = tmp_path / "declared.py"
    path.write_text(STRATEGY)
    return path


@pytest.mark.parametrize("bug", BUGS)
@pytest.mark.parametrize("path", PATHS)
def test_a_declared_rounds_bug_is_told_as_the_graph_tells_it(declared, bug, path, monkeypatch,
                                                            tmp_path):
    name, node, says, text = BUGS[bug]
    config = next(c for c in load_tasks("demo") if len(c.agent_ids) >= 2)
    spec = EpisodeSpec(config, planner=f"{declared}:{name}", obs_mode="blind",
                       models={"*": "greedy"}, max_steps=30)
    trajectory = tmp_path / "trajectory.json"
    with pytest.raises(PlannerNodeError) as raised:
        play(spec, path, monkeypatch, trajectory_path=trajectory)
    failure = raised.value.failure
    line = next(i for i, row in enumerate(STRATEGY.splitlines(), start=1) if text in row)
    assert (failure.node, failure.file, failure.line) == (node, str(declared), line)
    assert failure.headline().startswith(says)
    assert "cocobench_agents" not in failure.describe()  # no frame of the loop or LangGraph
    assert trajectory.exists()


def test_a_round_is_refused_when_a_fan_out_has_no_node_to_take_its_branches():
    async def nothing(state, runtime):
        return {}

    with pytest.raises(ValueError, match="fan-out 'a' must be followed by a node"):
        Rounds((FanOut("a", lambda state: [], nothing), FanOut("b", lambda state: [], nothing)))
    Rounds((Node("a", nothing), FanOut("b", lambda state: [], nothing)))  # b feeds a's round
    with pytest.raises(ValueError, match="distinct names"):
        Rounds((Node("a", nothing), Node("a", nothing)))


@pytest.mark.filterwarnings("error::pytest.PytestUnraisableExceptionWarning")
def test_an_episode_left_in_a_fan_out_on_a_closed_loop_is_collected_quietly():
    """An environment dropped mid-round: its loop closed before the garbage collector closes
    the episode's coroutine, which is waiting in a fan-out; that must not raise 'Event loop
    is closed' (an 'Exception ignored' at a script's exit)."""
    import gc

    from cocobench_agents.graphs.rounds import _fan_out

    async def wait_forever(branch, runtime):
        await asyncio.Event().wait()

    step = FanOut("wait", lambda state: [{}], wait_forever)
    loop = asyncio.new_event_loop()
    coroutine = _fan_out(step, [{}, {}], None, False)
    played = loop.create_task(coroutine)
    loop.run_until_complete(asyncio.sleep(0))
    assert not played.done()
    loop.close()
    del played
    coroutine.close()  # what the collector does with the abandoned episode
    gc.collect()
