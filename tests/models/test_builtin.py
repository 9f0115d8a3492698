"""The offline clients: greedy, random, scripted, replay."""

from __future__ import annotations

import asyncio
import json

import pytest

from cocobench_agents.models import (
    GREEDY_SKILL_ORDER,
    MenuOption,
    ModelClient,
    ModelConfigError,
    ModelError,
    ModelPool,
    ModelReply,
    ModelRequest,
    ModelSettings,
)

MENU = (
    MenuOption(7, "Find", "Find(agent_1, Knife)"),
    MenuOption(9, "Open", "Open(agent_1, Fridge)"),
    MenuOption(11, "Wait", "Wait(agent_1)"),
    MenuOption(13, "Open", "Open(agent_1, Drawer)"),
    MenuOption(20, "Explore", "Explore(agent_1)"),
)


def ask(client: ModelClient, menu=MENU, **kw) -> ModelReply:
    return asyncio.run(client.complete(ModelRequest(prompt="p", menu=menu, **kw)))


def texts(client: ModelClient, n: int, menu=MENU, **kw) -> list[str]:
    return [ask(client, menu, **kw).text for _ in range(n)]


def make(spec: str, *, episode: str = "ep", agent: str | None = None, **settings) -> ModelClient:
    return ModelPool(ModelSettings(**settings)).client(spec, episode=episode, agent=agent)


# -- greedy ----------------------------------------------------------------------------------


def test_greedy_takes_the_lowest_rank_skill_first_in_its_tier():
    client = make("greedy")
    assert isinstance(client, ModelClient) and client.name == "greedy"
    reply = ask(client)
    assert reply == ModelReply(text="ACTION: 9")  # Open beats Find/Wait/Explore; 9 before 13
    assert ask(client, MENU[2:3] + MENU[4:]).text == "ACTION: 20"  # Explore before Wait


def test_greedy_follows_the_reference_order():
    menu = tuple(MenuOption(100 - i, s, s) for i, s in enumerate(reversed(GREEDY_SKILL_ORDER)))
    expected = 100 - (len(GREEDY_SKILL_ORDER) - 1)  # PickUp, listed last
    assert ask(make("greedy"), menu).text == f"ACTION: {expected}"
    unknown_first = (MenuOption(1, "Teleport", "T()"), MenuOption(2, "Wait", "Wait()"))
    assert ask(make("greedy"), unknown_first).text == "ACTION: 2"


def test_greedy_says_done_on_an_empty_menu():
    assert ask(make("greedy"), ()).text == "ACTION: DONE"


# -- random ----------------------------------------------------------------------------------


def test_random_is_uniform_over_the_menu_and_never_done():
    seen = texts(make("random:1"), 300)
    ids = {int(t.removeprefix("ACTION: ")) for t in seen}
    assert ids == {o.action_id for o in MENU}
    assert all(t.startswith("ACTION: ") and "DONE" not in t for t in seen)


def test_random_is_reproducible_per_seed_episode_and_agent():
    run = lambda spec, **kw: texts(make(spec, **kw), 20)  # noqa: E731
    assert run("random:7") == run("random:7")
    assert run("random:7") != run("random:8")
    assert run("random:7", agent="agent_1") == run("random:7", agent="agent_1")
    assert run("random:7", agent="agent_1") != run("random:7", agent="agent_2")
    assert run("random:7", episode="a") != run("random:7", episode="b")
    # The seed comes from the settings when the spec has none.
    assert run("random", seed=7) == run("random:7")
    assert run("random") == run("random:0")


def test_random_streams_per_sample_and_agents_are_independent():
    client = make("random:3", agent="agent_1")
    assert texts(client, 10, sample_index=0) != texts(
        make("random:3", agent="agent_1"), 10, sample_index=1
    )
    # Interleaving another agent's calls does not change this agent's stream.
    pool = ModelPool()
    a1 = pool.client("random:3", episode="ep", agent="agent_1")
    a2 = pool.client("random:3", episode="ep", agent="agent_2")
    mixed = []
    for _ in range(10):
        mixed.append(ask(a1).text)
        ask(a2)
    assert mixed == texts(make("random:3", agent="agent_1"), 10)


def test_random_says_done_only_on_an_empty_menu():
    assert ask(make("random"), ()).text == "ACTION: DONE"


# -- scripted --------------------------------------------------------------------------------


def test_scripted_json_list_in_order_then_done(tmp_path):
    path = tmp_path / "replies.json"
    path.write_text(json.dumps(["REASON: a\nACTION: 9", "ACTION: 7"]))
    client = make(f"scripted:{path}")
    assert client.name == f"scripted:{path}"
    assert texts(client, 4) == ["REASON: a\nACTION: 9", "ACTION: 7", "ACTION: DONE", "ACTION: DONE"]
    # Every agent (and every episode) starts the list afresh.
    assert ask(make(f"scripted:{path}", agent="agent_2")).text == "REASON: a\nACTION: 9"


def test_scripted_json_object_per_agent(tmp_path):
    path = tmp_path / "replies.json"
    path.write_text(
        json.dumps({"agent_1": ["ACTION: 1"], "centralized": ["ACTION: 5"], "*": ["ACTION: 8"]})
    )
    assert texts(make(f"scripted:{path}", agent="agent_1"), 2) == ["ACTION: 1", "ACTION: DONE"]
    assert ask(make(f"scripted:{path}", agent=None)).text == "ACTION: 5"
    assert ask(make(f"scripted:{path}", agent="agent_3")).text == "ACTION: 8"


def test_scripted_text_file_separated_by_dashes(tmp_path):
    path = tmp_path / "replies.txt"
    path.write_text("REASON: first\nACTION: 9\n---\nACTION: 7\nMSG: on my way\n  ---  \n\n---\n")
    assert texts(make(f"scripted:{path}"), 3) == [
        "REASON: first\nACTION: 9",
        "ACTION: 7\nMSG: on my way",
        "ACTION: DONE",
    ]


@pytest.mark.parametrize(
    ("name", "content", "fragment"),
    [
        ("missing.json", None, "cannot read"),
        ("bad.json", "[1, 2", "not valid JSON"),
        ("ints.json", "[1, 2]", "list of strings"),
        ("scalar.json", "3", "list or an object"),
    ],
)
def test_scripted_file_errors_are_config_errors(tmp_path, name, content, fragment):
    path = tmp_path / name
    if content is not None:
        path.write_text(content)
    spec = f"scripted:{path}"
    with pytest.raises(ModelConfigError, match=fragment) as info:
        ModelPool().validate(spec)
    assert str(info.value).startswith(spec) and "\n" not in str(info.value)


# -- replay ----------------------------------------------------------------------------------


def trajectory(task_id: str, decisions=None, items=None) -> dict:
    data: dict = {"task_id": task_id, "trajectory": items or []}
    if decisions is not None:
        data["planner_decisions"] = decisions
    return data


def write(path, data) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data))


def test_replay_planner_decisions_per_agent(tmp_path):
    path = tmp_path / "trajectory.json"
    write(path, trajectory("T1", decisions=[
        {"agent": "agent_1", "raw_output": "ACTION: 9"},
        {"agent": "agent_2", "raw_output": "ACTION: 20"},
        {"agent": "agent_1", "raw_output": "ACTION: 13"},
        {"agent": "agent_2", "raw_output": None, "error": "timeout"},  # no output: skipped
    ]))  # fmt: skip
    a1 = make(f"replay:{path}", episode="T1", agent="agent_1")
    assert texts(a1, 2) == ["ACTION: 9", "ACTION: 13"]
    with pytest.raises(ModelError) as info:
        ask(a1)
    assert info.value.kind == "other" and "exhausted" in info.value.message
    assert texts(make(f"replay:{path}", episode="T1", agent="agent_2"), 1) == ["ACTION: 20"]


def test_replay_falls_back_to_policy_decisions_of_items(tmp_path):
    items = [
        {"step_index": 0, "label": "init"},
        {"step_index": 1, "policy_decision": {"raw_output": "REASON: x\nACTION: 9"}},
        {"step_index": 2, "policy_decision": {"raw_output": "ACTION: DONE"}},
    ]
    path = tmp_path / "trajectory.json"
    write(path, trajectory("T1", items=items))
    assert texts(make(f"replay:{path}", episode="T1"), 2) == [
        "REASON: x\nACTION: 9",
        "ACTION: DONE",
    ]


def test_replay_folder_finds_the_episode_trajectory(tmp_path):
    for condition, task_id in [("C0", "T1"), ("C1", "T1"), ("C0", "T2")]:
        write(
            tmp_path / "run" / condition / task_id / "trajectory.json",
            trajectory(task_id, [{"agent": None, "raw_output": f"{condition}-{task_id}"}]),
        )
    (tmp_path / "run" / "C0" / "broken").mkdir()
    (tmp_path / "run" / "C0" / "broken" / "trajectory.json").write_text("{oops")
    spec = f"replay:{tmp_path}"
    ModelPool().validate(spec)
    assert ask(make(spec, episode="T2")).text == "C0-T2"
    assert ask(make(spec, episode="C1/T1")).text == "C1-T1"  # the path says which run
    with pytest.raises(ModelError, match="2 recorded trajectories"):
        ask(make(spec, episode="T1"))
    with pytest.raises(ModelError, match="no recorded trajectory"):
        ask(make(spec, episode="T9"))  # fmt: skip


def test_replay_path_errors_are_config_errors(tmp_path):
    with pytest.raises(ModelConfigError, match="does not exist"):
        ModelPool().validate(f"replay:{tmp_path / 'nope'}")
    with pytest.raises(ModelConfigError, match=r"no readable trajectory\.json"):
        ModelPool().validate(f"replay:{tmp_path}")


def test_builtins_are_free_and_instant(tmp_path):
    path = tmp_path / "r.json"
    path.write_text('["ACTION: 9"]')
    for spec in ("greedy", "random", f"scripted:{path}"):
        reply = ask(make(spec))
        assert (reply.prompt_tokens, reply.completion_tokens, reply.cost_usd) == (0, 0, 0.0)
        assert reply.latency_s == 0.0 and reply.retries == 0 and not reply.cached


def test_the_team_seat_is_keyed_team_and_old_scripts_still_read(tmp_path):
    """A script keys the team's model (a centralized planner's, a leader's) by the team's
    one seat name, "team"; a file written when it was keyed by the planner's name,
    "centralized", still reads, and "team" wins where both are given."""
    both = tmp_path / "both.json"
    both.write_text(json.dumps({"team": ["ACTION: 2"], "centralized": ["ACTION: 5"]}))
    assert ask(make(f"scripted:{both}", agent=None)).text == "ACTION: 2"
    old = tmp_path / "old.json"
    old.write_text(json.dumps({"centralized": ["ACTION: 5"], "*": ["ACTION: 8"]}))
    assert ask(make(f"scripted:{old}", agent=None)).text == "ACTION: 5"
    assert ask(make(f"scripted:{old}", agent="agent_1")).text == "ACTION: 8"
