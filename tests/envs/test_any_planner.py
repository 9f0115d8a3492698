"""Any planner is an environment: the environment plays the planner's own graph, knowing it
only by its spec, so a plugin (claim-board, installed with an entry point) passes the
ecosystem's checkers, scores as `cocobench run` scores the same replies, seats a person, and
`envs/seated.py` names no planner."""

from __future__ import annotations

import ast
import json
import re
from pathlib import Path

import pytest

import cocobench_agents as cb
from benchmark_adapter.tasks import load_tasks
from tests.paths import SHARED_TASKS

pytestmark = [pytest.mark.needs_env, pytest.mark.usefixtures("quiet")]

TASKS = str(SHARED_TASKS)
REAL = "A_D1__FloorPlan1__seed0"  # agents agent_1, agent_2
ENVS = Path(__file__).resolve().parents[2] / "cocobench_agents" / "envs"
EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def claim_board() -> str:
    """The claim-board planner's name, or skip where its example package is not installed."""
    from cocobench_agents.graphs import find_planner

    name = find_planner("CL")
    if name is None:
        pytest.skip("examples/claim-board is not installed (pip install -e examples/claim-board)")
    return name


def test_claim_board_passes_pettingzoos_parallel_api_test():
    from pettingzoo.test import parallel_api_test

    from cocobench_agents.envs import parallel_env

    claim_board()
    environment = parallel_env(TASKS, condition="CL_blind", task_id=REAL, seed=0)
    parallel_api_test(environment, num_cycles=40)


def test_claim_board_asks_its_robots_one_after_another():
    """Claim-board decides in turn, each robot reading the claims made before it: the
    environment asks one robot per step, and a claim lands on the board the next one reads."""
    from cocobench_agents.envs import parallel_env

    claim_board()
    environment = parallel_env(TASKS, condition="CL_blind", task_id=REAL, max_steps=6)
    observations, _ = environment.reset(seed=0)
    asked = []
    while environment.agents:
        acting = [s for s in environment.agents if observations[s]["action_mask"][1:].any()]
        asked.append(acting)
        first = {s: int(observations[s]["action_mask"][1:].argmax()) for s in acting}
        observations, *_ = environment.step({s: {"action": first.get(s, -1), "message": ""}
                                             for s in environment.agents})
    assert asked and all(len(a) == 1 for a in asked)
    assert {a[0] for a in asked} == {"agent_1", "agent_2"}
    claims = [d for d in environment.episode.tools.decisions
              if (d.get("message") or "").startswith("claims: ")]
    assert claims  # the robots' choices were posted as claims


@pytest.mark.parametrize("seat", ["agent_1", "agent_2"])
def test_a_claim_board_seat_learns_beside_a_model_partner(seat):
    """The single-seat Gymnasium environment over a plugin planner: passes Gymnasium's
    checker, its partner played by a built-in model."""
    from gymnasium.utils.env_checker import check_env

    from cocobench_agents.envs import SeatEnv

    claim_board()
    environment = SeatEnv(TASKS, condition="CL_blind", seat=seat, partner="random",
                          task_id=REAL, max_steps=8)
    check_env(environment, skip_render_check=True)
    environment.close()


def test_a_claim_board_episode_scores_as_its_scripted_run(tmp_path):
    from tests.envs.test_equality import differences, scored_both_ways

    planner = claim_board()
    config = load_tasks(SHARED_TASKS)[0]
    env_result, run_result = scored_both_ways(config, planner, "random", tmp_path, 0)
    assert differences(env_result, run_result) == {}
    assert env_result.num_steps > 0 and env_result.condition == "CL_blind"


def test_a_strategy_in_a_users_file_is_an_environment(tmp_path):
    """A strategy in the researcher's own file (the first-come example, copied out of the
    repository): PettingZoo's API test passes, and an episode scores as its scripted run."""
    from pettingzoo.test import parallel_api_test

    from cocobench_agents.envs import parallel_env
    from tests.envs.test_equality import differences, scored_both_ways

    mine = tmp_path / "mine.py"
    mine.write_text((EXAMPLES / "strategies" / "first_come.py").read_text(encoding="utf-8"))
    planner = f"{mine}:FIRST_COME"
    environment = parallel_env(TASKS, condition=f"{planner}_blind", task_id=REAL, seed=0)
    assert environment.possible_agents == ["agent_1", "agent_2"]
    parallel_api_test(environment, num_cycles=20)
    env_result, run_result = scored_both_ways(load_tasks(SHARED_TASKS)[0], planner, "random",
                                              tmp_path, 0)
    assert differences(env_result, run_result) == {} and env_result.num_steps > 0


def test_a_planner_that_calls_no_model_has_no_seat():
    from cocobench_agents.envs import EnvError, parallel_env

    with pytest.raises(EnvError, match=r"'oracle' \(OR\) calls no model: it has no seat"):
        parallel_env(TASKS, condition="OR_blind", task_id=REAL)


def test_a_person_plays_a_claim_board_seat(tmp_path):
    """A human seat on claim-board (`cocobench run --agent-model agent_1=human`): every
    decision of the seat, its second asks after a conflict too, goes to the person's desk
    and is recorded as the person's; the episode scores as the same replies scripted."""
    from tests.human.desks import TASK, OracleDesk, oracle_calls

    claim_board()
    calls = oracle_calls(tmp_path / "oracle")
    desk = OracleDesk([c for c in calls if c.partition("(")[2].startswith("agent_1")])
    teammate = tmp_path / "teammate.txt"
    teammate.write_text("REASON: I wait\nACTION: DONE")
    selection = {"sources": ["demo"], "task_ids": [TASK]}
    played = cb.run(cb.RunRequest(out=tmp_path / "human", models=[f"scripted:{teammate}"],
                                  agent_models={"agent_1": "human"}, selection=selection,
                                  conditions=["CL_blind"]), desk=desk)[0]
    assert played["models"] == {"agent_1": "human", "agent_2": f"scripted:{teammate}"}
    assert played["num_steps"] > 0 and desk.asked
    assert {d.seat for d in desk.asked} == {"agent_1"}
    document = json.loads((tmp_path / "human" / played["trajectory"]).read_text())
    mine = [d for d in document["planner_decisions"]
            if d["agent"] == "agent_1" and d.get("prompt_hash")]
    assert len(mine) == len(desk.asked) and {d["model"] for d in mine} == {"human"}

    script = tmp_path / "replies.json"
    script.write_text(json.dumps({"agent_1": desk.reply_texts(),
                                  "agent_2": ["REASON: I wait\nACTION: DONE"] * 99}))
    scripted = cb.run(cb.RunRequest(out=tmp_path / "scripted", models=[f"scripted:{script}"],
                                    selection=selection, conditions=["CL_blind"]))[0]
    same = ("task_success", "task_progress", "num_steps", "failed_steps", "terminal_reason",
            "construct_score")
    assert {k: played[k] for k in same} == {k: scripted[k] for k in same}


def test_the_environment_names_no_planner():
    """`envs/` knows a planner by its spec alone: no planner's name, code, graph module or
    build function appears in the code of the modules that step an episode (docstrings
    aside). The reference plan as a partner (`oracle_partner.py`) is a model, not a
    planner: ``oracle`` may appear."""
    from cocobench_agents.graphs import ORACLE, PLANNERS

    planners = {*PLANNERS, *(s.code for s in PLANNERS.values()), "claim-board",
                "claim_board", "centralized", "decentralized", "leader_worker"}
    for name in ("seated.py", "turns.py"):
        words = code_words(ENVS / name)
        named = sorted(w for w in words if w in planners - {ORACLE, "OR"}
                       or w.startswith("build_") or w == "STEPPED_GRAPHS")
        assert named == [], f"envs/{name} names {named}"


def code_words(path: Path) -> set[str]:
    """The identifiers, imported names and string words of a module's code, docstrings
    left out."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    docstrings = {id(node.body[0].value) for node in ast.walk(tree)
                  if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef,
                                       ast.AsyncFunctionDef))
                  and node.body and isinstance(node.body[0], ast.Expr)}
    words: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Name):
            words.add(node.id)
        elif isinstance(node, ast.Attribute):
            words.add(node.attr)
        elif isinstance(node, ast.alias):
            words.update(node.name.split("."))
        elif isinstance(node, ast.ImportFrom) and node.module:
            words.update(node.module.split("."))
        elif isinstance(node, ast.Constant) and isinstance(node.value, str) \
                and id(node) not in docstrings:
            words.update(re.findall(r"[\w-]+", node.value))
    return words
