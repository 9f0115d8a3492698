"""The example strategy package (examples/claim-board): its claiming rule, and the package
installed with pip, found through its entry point, run and scored end to end."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from benchmark_adapter.trajectory import PROMPTS_FIELD
from cocobench_agents.episode_runner import EpisodeSpec
from cocobench_agents.graphs.plugins import forget_user_planners

from .conftest import run

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "claim-board"
FIND_BOOK = {"agent_1": "ACTION: 0", "agent_2": "ACTION: 24"}  # G_D1's first menu
FIND_REMOTE_2 = "ACTION: 26"


@pytest.fixture
def claim_board(monkeypatch) -> str:
    """The example package from this checkout (ahead of any installed copy)."""
    monkeypatch.syspath_prepend(str(EXAMPLE))
    for name in [m for m in sys.modules if m.startswith("cocobench_claim_board")]:
        monkeypatch.delitem(sys.modules, name)
    forget_user_planners()
    yield "cocobench_claim_board:CLAIM_BOARD"
    forget_user_planners()


def steps(document) -> list[dict]:
    return [i for i in document["trajectory"] if "skill_result" in i]


def prompt_of(document, decision) -> str:
    return document[PROMPTS_FIELD][decision["prompt_hash"]]


def test_its_spec_declares_its_shape(claim_board):
    from cocobench_agents.graphs import planner_spec

    spec = planner_spec(claim_board)
    assert (spec.loop, spec.calls_per_seat, spec.prompt_kind, spec.broadcast) == \
        ("round", 2, "agent", True)
    assert spec.declares_loop and spec.most_calls(agent_count=2, budget=3) == 12


@pytest.mark.slow
def test_its_dry_run_is_exact_against_a_real_run(claim_board, demo, tmp_path):
    """The estimate from the spec's declared shape, against the calls a run with a remote
    model (the fake OpenAI server) sends: no more than max_calls, and a first round of the
    estimated tokens. Robot 1's first answer claims nothing (an Explore), so robot 2's first
    prompt shows the board the estimate renders: empty."""
    from cocobench_agents import plan
    from cocobench_agents.engine import RunRequest
    from cocobench_agents.models import ModelPool, ModelSettings, import_litellm
    from tests.models.fake_openai import FakeOpenAI, ok

    model, config = "openai/test-model", demo["G_D1"]
    explore = next(e.action_id for e in _first_menu(config) if e.skill == "Explore")
    with FakeOpenAI(default=ok("REASON: go\nACTION: 1")) as server:
        settings = ModelSettings(api_base=server.base_url)
        request = RunRequest(out=tmp_path / "run", models=[model], planners=[claim_board],
                             obs_modes=["blind"], max_steps=3, model_settings=settings,
                             selection={"sources": ["demo"], "task_ids": [config.task_id]})
        (row,) = plan(request).rows
        assert server.count == 0 and not row.assumed  # declared: counted, not assumed
        assert row.max_calls == 2 * config.agent_count * 3
        server.program(ok(f"REASON: look\nACTION: {explore}"))
        spec = EpisodeSpec(config, planner=claim_board, models={"*": model},
                           obs_mode="blind", max_steps=3)
        document, _ = run(spec, ModelPool(settings))
    assert 0 < server.count <= row.max_calls
    decisions = document["planner_decisions"]
    assert len(decisions) >= 2 and decisions[0]["status"] == "action"
    first_round = server.requests[:config.agent_count]
    sent = sum(import_litellm().token_counter(model=model, messages=r["messages"])
               for r in first_round)
    assert sent == row.prompt_tokens


def _first_menu(config):
    from benchmark_adapter.episode import Episode
    from cocobench_agents.prompts import DEFAULT_SUITE, load_prompt_suite
    from cocobench_agents.tools import EpisodeTools

    tools = EpisodeTools(Episode(config), load_prompt_suite(DEFAULT_SUITE), obs_mode="blind")
    tools.start()
    return tools.prompt("agent_1", [], broadcast=True, with_images=False)[2]


def test_calls_claim_the_object_they_work_on(claim_board):
    from cocobench_claim_board.graph import claimed_object

    assert claimed_object("PickUp(agent_1, Apple|+01.00|+00.90|-00.20)") == \
        "Apple|+01.00|+00.90|-00.20"
    assert claimed_object("Find(agent_2, Fridge|-02.00|+00.00|+01.00)") == \
        "Fridge|-02.00|+00.00|+01.00"
    for call in ("Put(agent_1, Fridge|-02.00|+00.00|+01.00)", "Explore(agent_1, left)",
                 "Wait(agent_2)", "Drop(agent_1)", None):
        assert claimed_object(call) is None


def test_a_claimed_object_sends_the_teammate_back_to_choose(claim_board, demo, script):
    model = script({"agent_1": [FIND_BOOK["agent_1"], "ACTION: DONE"],
                    "agent_2": [FIND_BOOK["agent_2"], FIND_REMOTE_2, "ACTION: DONE"]})
    document, result = run(EpisodeSpec(demo["G_D1"], planner=claim_board,
                                       models={"*": model}, obs_mode="blind"))
    landed = steps(document)
    assert [s["label"] for s in landed] == ["Find(agent_1, Book|+01.20|+00.55|-00.80)",
                                             "Find(agent_2, RemoteControl|-01.10|+00.45|+00.90)"]
    assert [s["message"] for s in landed] == ["claims: find a Book",
                                               "claims: find a RemoteControl"]
    first, conflict, second, *_ = document["planner_decisions"]
    assert (first["agent"], conflict["agent"], second["agent"]) == \
        ("agent_1", "agent_2", "agent_2")
    assert conflict["status"] == "claim_conflict" and conflict["claimed_by"] == "agent_1"
    assert conflict["wanted_call"] == "Find(agent_2, Book|+01.20|+00.55|-00.80)"
    # agent_2 read agent_1's claim before choosing, and the conflict before choosing again
    assert "agent_1: claims: find a Book" in prompt_of(document, conflict)
    assert "find a Book is claimed by agent_1; choose another" in prompt_of(document, second)
    assert result.terminal_reason == "done" and result.planner_steps == 5


def test_a_robot_that_insists_on_a_claimed_object_idles(claim_board, demo, script):
    model = script({"agent_1": [FIND_BOOK["agent_1"], "ACTION: DONE"],
                    "agent_2": [FIND_BOOK["agent_2"], FIND_BOOK["agent_2"], "ACTION: DONE"]})
    document, result = run(EpisodeSpec(demo["G_D1"], planner=claim_board,
                                       models={"*": model}, obs_mode="blind"))
    assert [s["label"] for s in steps(document)] == ["Find(agent_1, Book|+01.20|+00.55|-00.80)"]
    statuses = [(d["agent"], d["status"]) for d in document["planner_decisions"]]
    assert statuses[:3] == [("agent_1", "action"), ("agent_2", "claim_conflict"),
                            ("agent_2", "claim_conflict")]
    assert result.terminal_reason == "done"


@pytest.mark.slow
def test_the_package_installs_registers_and_runs_end_to_end(tmp_path):
    # A real pip install, offline, of a copy (pip builds in the source tree).
    source = tmp_path / "claim-board"
    shutil.copytree(EXAMPLE, source, ignore=shutil.ignore_patterns(
        "build", "*.egg-info", "__pycache__"))
    site = tmp_path / "site"
    subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps",
                    "--no-build-isolation", "--no-index", "--disable-pip-version-check",
                    "--target", str(site), str(source)], check=True, timeout=300)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(site), *filter(None, [os.environ.get("PYTHONPATH")])])}

    def cocobench(*argv: str) -> subprocess.CompletedProcess:
        done = subprocess.run([sys.executable, "-m", "cocobench_agents.cli", *argv],
                              capture_output=True, text=True, timeout=300, env=env)
        assert done.returncode == 0, done.stderr
        return done

    listed = {p["name"]: p for p in json.loads(cocobench("planners", "--json").stdout)}
    entry = listed["claim-board"]
    assert (entry["kind"], entry["code"], entry["distribution"]) == \
        ("entry point", "CL", "cocobench-claim-board 0.1.0")
    assert entry["file"].startswith(str(site))
    out = tmp_path / "run"
    cocobench("run", "--planner", "claim-board", "--model", "greedy", "--suite", "demo",
              "--out", str(out))
    cocobench("run", "--conditions", "CL_blind", "--model", "greedy", "--suite", "demo",
              "--limit", "1", "--out", str(tmp_path / "by-code"))
    rows = [json.loads(line) for line in (out / "results.jsonl").read_text().splitlines()]
    assert len(rows) == 4
    assert all(r["condition"] == "CL_image" and r["planner"] == "claim-board" for r in rows)
    assert all("infra_error" not in r and r["terminal_reason"] for r in rows)
    assert all(r["construct_status"] for r in rows)  # scored, not only recorded
    recorded = json.loads((out / "run.json").read_text())["planners"]["claim-board"]
    assert recorded["distribution"] == "cocobench-claim-board 0.1.0" and recorded["sha256"]


def test_its_round_is_declared_and_plays_as_its_graph(claim_board, monkeypatch):
    """Its graph is built from `claim_board_rounds`, and an episode awaiting the round's
    functions directly is the episode its graph plays, claim conflicts included."""
    from benchmark_adapter.tasks import load_tasks
    from cocobench_agents.graphs import compiled_graph, planner_rounds
    from tests.planners.test_rounds import comparable, play

    rounds = planner_rounds(claim_board)
    assert [s.name for s in rounds.steps] == ["claim_round", "land_round"]
    assert list(compiled_graph(claim_board).builder.nodes) == ["claim_round", "land_round"]
    config = next(c for c in load_tasks("demo") if len(c.agent_ids) == 3)
    spec = EpisodeSpec(config, planner=claim_board, obs_mode="blind", max_steps=30,
                       models={"*": "random:5", "agent_1": "random:9"})
    (direct, _), (graph, _) = (play(spec, path, monkeypatch) for path in ("rounds", "graph"))
    assert comparable(direct) == comparable(graph)
    assert "claim_conflict" in {d["status"] for d in direct["planner_decisions"]}
