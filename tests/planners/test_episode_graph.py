"""The `episode` graph: a whole episode from plain input, for LangGraph's own tooling; and a
real `langgraph dev` server running it through `langgraph_sdk`."""

from __future__ import annotations

import asyncio
import json
import os
import signal
import socket
import subprocess
import time
from pathlib import Path

import pytest

from cocobench_agents.episode_graph import build_episode_graph
from tests.conftest import LANGGRAPH_CLI

ROOT = Path(__file__).resolve().parents[2]
TASK = {"task": "G_D1__DemoLivingRoom1__seed0", "suite": "demo", "model": "greedy",
        "budget": 4}


def stream(graph, state):
    async def collect():
        return [chunk async for chunk in graph.astream(state, stream_mode=["custom", "values"])]

    return asyncio.run(collect())


def test_the_input_schema_is_a_form_studio_can_show():
    schema = build_episode_graph().compile().get_input_jsonschema()
    assert schema["required"] == ["task"]
    assert {"task", "model", "agent_models", "planner", "obs_mode", "budget", "backend"} <= set(
        schema["properties"])
    assert schema["properties"]["obs_mode"]["enum"] == ["image", "blind"]


def test_an_episode_streams_each_landed_step_and_returns_its_score():
    chunks = stream(build_episode_graph().compile(), TASK)
    steps = [c for mode, c in chunks if mode == "custom"]
    final = next(c for mode, c in reversed(chunks) if mode == "values")
    assert [s["step"] for s in steps] == [1, 2, 3, 4]
    assert steps[0]["call"].startswith("PickUp(agent_1,")
    result = final["result"]
    assert result["task_id"] == TASK["task"] and result["num_steps"] == 4
    assert result["terminal_reason"] == "max_steps" and result["model"] == "greedy"
    assert [s["call"] for s in final["trajectory"]["steps"]] == [s["call"] for s in steps]


def test_the_oracle_planner_solves_its_instance():
    state = {**TASK, "planner": "oracle"}
    state.pop("budget")
    final = stream(build_episode_graph().compile(), state)[-1][1]
    assert final["result"]["task_success"] == 1


def test_model_settings_are_the_run_requests(tmp_path):
    from tests.models.fake_openai import FakeOpenAI, ok

    with FakeOpenAI(default=ok("REASON: go\nACTION: 1")) as server:
        state = {**TASK, "model": "openai/fake", "budget": 2,
                 "model_settings": {"api_base": server.base_url, "temperature": 0.4,
                                    "transport": "http"}}
        final = stream(build_episode_graph().compile(), state)[-1][1]
        assert server.count >= 1
        assert all(body["temperature"] == 0.4 for body in server.requests)
    assert final["result"]["num_steps"] == 2
    with pytest.raises(ValueError, match="timeout_s"):
        stream(build_episode_graph().compile(), {**TASK, "model_settings": {"timeout_s": 0}})


def test_an_unknown_task_names_itself():
    with pytest.raises(ValueError, match="unknown task 'nope'"):
        stream(build_episode_graph().compile(), {"task": "nope", "suite": "demo"})


def play_by_interrupts(graph, state, answer):
    """Run `state` on `graph` (with a checkpointer), resuming each interrupt with
    `answer(decision)`; the asked decisions, the custom events, the final values."""
    from langgraph.types import Command

    config = {"configurable": {"thread_id": "play"}}
    asked, steps, final = [], [], None
    given = state
    while True:
        interrupted = None
        for mode, chunk in _sync_stream(graph, given, config):
            if mode == "custom":
                steps.append(chunk)
            elif "__interrupt__" in chunk:
                interrupted = chunk["__interrupt__"][0].value
            else:
                final = chunk
        if interrupted is None:
            return asked, steps, final
        asked.append(interrupted)
        given = Command(resume=answer(interrupted))


def _sync_stream(graph, given, config):
    """The custom events, the values and the interrupt (an update) of one run."""
    async def collect():
        return [c async for c in graph.astream(given, config,
                                               stream_mode=["custom", "values", "updates"])
                if c[0] != "updates" or "__interrupt__" in c[1]]

    return asyncio.run(collect())


def test_a_human_seat_pauses_at_each_of_its_decisions():
    from langgraph.checkpoint.memory import InMemorySaver

    graph = build_episode_graph().compile(checkpointer=InMemorySaver())
    state = {**TASK, "planner": "decentralized-broadcast", "obs_mode": "blind",
             "agent_models": {"agent_1": "human"}}
    asked, steps, final = play_by_interrupts(graph, state, lambda d: {
        "action_id": d["menu"][0]["id"], "message": f"my move {d['step_index']}"})
    assert asked and {d["seat"] for d in asked} == {"agent_1"}
    assert all(d["wants_message"] and d["prompt"] and d["menu"] for d in asked)
    assert [d["id"].rpartition("#")[2] for d in asked] == [str(n + 1) for n in range(len(asked))]
    result = final["result"]
    assert result["models"] == {"agent_1": "human", "agent_2": "greedy"}
    assert result["num_steps"] == 4
    assert [s["step"] for s in steps] == [1, 2, 3, 4]  # each once, though replayed


def test_several_human_seats_are_asked_in_the_planners_order():
    from langgraph.checkpoint.memory import InMemorySaver

    graph = build_episode_graph().compile(checkpointer=InMemorySaver())
    state = {**TASK, "model": "human", "planner": "decentralized", "obs_mode": "blind"}
    asked, _, final = play_by_interrupts(graph, state,
                                         lambda d: {"action_id": d["menu"][-1]["id"]})
    assert [d["id"].partition("#")[2] for d in asked] == [
        "agent_1#1", "agent_2#1", "agent_1#2", "agent_2#2"]  # round by round, agent order
    assert final["result"]["num_steps"] == 4


def test_a_resume_off_the_menu_is_refused_and_can_be_answered_again():
    from langgraph.checkpoint.memory import InMemorySaver
    from langgraph.types import Command
    from pydantic import ValidationError

    graph = build_episode_graph().compile(checkpointer=InMemorySaver())
    config = {"configurable": {"thread_id": "refused"}}
    first = asyncio.run(graph.ainvoke({**TASK, "model": "human", "budget": 1}, config))
    decision = first["__interrupt__"][0].value
    with pytest.raises(ValidationError, match="action 9999 is not on the menu"):
        asyncio.run(graph.ainvoke(Command(resume={"action_id": 9999}), config))
    final = asyncio.run(graph.ainvoke(
        Command(resume={"action_id": decision["menu"][0]["id"]}), config))
    assert final["result"]["num_steps"] == 1 and final["result"]["model"] == "human"
    done = asyncio.run(graph.ainvoke({**TASK, "model": "human"},
                                     {"configurable": {"thread_id": "done"}}))
    final = asyncio.run(graph.ainvoke(Command(resume={"action_id": None}),
                                      {"configurable": {"thread_id": "done"}}))
    assert done["__interrupt__"] and final["result"]["terminal_reason"] == "done"


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="module")
def langgraph_server(tmp_path_factory):
    """`langgraph dev` on 127.0.0.1, serving a copy of this repository's langgraph.json (the
    server writes its state beside the config: in a temporary copy, not the checkout); its
    tests are marked `needs_langgraph_cli`."""
    work = tmp_path_factory.mktemp("langgraph")
    config = json.loads((ROOT / "langgraph.json").read_text())
    config["dependencies"] = [str(ROOT)]
    config["graphs"] = {"episode": str(ROOT / config["graphs"]["episode"])}
    (work / "langgraph.json").write_text(json.dumps(config))
    port = _free_port()
    env = {**os.environ, "LANGGRAPH_CLI_NO_ANALYTICS": "1", "LANGSMITH_TRACING": "false"}
    log = (work / "server.log").open("w")
    server = subprocess.Popen(
        [str(LANGGRAPH_CLI), "dev", "--no-browser", "--host", "127.0.0.1", "--port", str(port),
         "--config", str(work / "langgraph.json"), "--no-reload"],
        cwd=work, stdout=log, stderr=subprocess.STDOUT, env=env, start_new_session=True)
    url = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        try:
            with socket.create_connection(("127.0.0.1", port), timeout=1):
                break
        except OSError:
            if server.poll() is not None:
                pytest.fail(f"langgraph dev exited: {(work / 'server.log').read_text()[-2000:]}")
            time.sleep(0.5)
    yield url
    os.killpg(server.pid, signal.SIGTERM)
    try:
        server.wait(timeout=30)
    except subprocess.TimeoutExpired:
        os.killpg(server.pid, signal.SIGKILL)
    log.close()


@pytest.mark.slow
@pytest.mark.needs_langgraph_cli
def test_langgraph_dev_runs_an_episode_through_the_sdk(langgraph_server):
    from langgraph_sdk import get_client

    async def run():
        client = get_client(url=langgraph_server)
        for _ in range(60):  # the server answers before it has loaded the graphs
            assistants = await client.assistants.search(graph_id="episode")
            if assistants:
                break
            await asyncio.sleep(1)
        thread = await client.threads.create()
        final = await client.runs.wait(thread["thread_id"], "episode", input=TASK)
        events = [part async for part in client.runs.stream(
            None, "episode", input={**TASK, "planner": "oracle", "budget": 20},
            stream_mode=["custom", "values"])]
        return final, events

    final, events = asyncio.run(run())
    assert final["result"]["task_id"] == TASK["task"]
    assert final["result"]["num_steps"] == 4
    steps = [e.data for e in events if e.event == "custom"]
    assert steps and all("call" in s for s in steps)
    last = [e.data for e in events if e.event == "values"][-1]
    assert last["result"]["task_success"] == 1


@pytest.mark.slow
@pytest.mark.needs_langgraph_cli
def test_langgraph_dev_asks_a_human_seat_through_interrupts(langgraph_server):
    from langgraph_sdk import get_client

    human = {**TASK, "model": "human", "budget": 2, "obs_mode": "blind"}

    async def run():
        client = get_client(url=langgraph_server)
        for _ in range(60):  # the server answers before it has loaded the graphs
            if await client.assistants.search(graph_id="episode"):
                break
            await asyncio.sleep(1)
        thread = (await client.threads.create())["thread_id"]
        first = await client.runs.wait(thread, "episode", input=human)
        refused = await client.runs.wait(thread, "episode", raise_error=False,
                                         command={"resume": {"action_id": 9999}})
        still = await client.threads.get_state(thread)
        menu = first["__interrupt__"][0]["value"]["menu"]
        second = await client.runs.wait(thread, "episode", command={"resume": {
            "action_id": menu[0]["id"], "reason": "closest"}})
        last = second["__interrupt__"][0]["value"]
        parts = [part async for part in client.runs.stream(
            thread, "episode", command={"resume": {"action_id": last["menu"][0]["id"]}},
            stream_mode=["custom", "values"])]
        return first, refused, still, second, parts

    first, refused, still, second, parts = asyncio.run(run())
    interrupt = first["__interrupt__"][0]
    assert interrupt["value"]["seat"] == "team" and interrupt["value"]["step_index"] == 0
    assert interrupt["response_schema"]["properties"]["action_id"]
    assert "action 9999 is not on the menu" in refused["__error__"]["message"]
    assert still["next"] == ["ask"]
    assert second["__interrupt__"][0]["value"]["step_index"] == 1
    assert [p.data["step"] for p in parts if p.event == "custom"] == [2]  # the new step only
    final = [p.data for p in parts if p.event == "values"][-1]["result"]
    assert final["model"] == "human" and final["num_steps"] == 2
