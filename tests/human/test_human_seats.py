"""`human` is a model: a person's decisions come from a desk (here, code playing a person in
this process), are recorded like a model's, scored like any episode, logged as they are
given, and replayed when a killed run resumes."""

from __future__ import annotations

import asyncio
import errno
import json
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest

import cocobench_agents as cb
from cocobench_agents.engine.errors import RequestError, RunFolderFailed
from cocobench_agents.harness.human_log import HUMAN_ANSWERS, LoggedDesk, answers_file
from cocobench_agents.models import ModelConfigError, ModelPool
from cocobench_agents.models.human import Answer, Decision
from cocobench_agents.models.preflight import preflight
from cocobench_agents.runfolder import json_lines
from cocobench_agents.runfolder.episode_key import EpisodeKey
from cocobench_agents.runfolder.errors import RunFolderError
from cocobench_agents.runfolder.folder import RunFolder
from tests.human.desks import TASK, OracleDesk, oracle_calls

ROOT = Path(__file__).resolve().parents[2]
SELECTION = {"sources": ["demo"], "task_ids": [TASK]}
#: What differs between two plays with the same choices: how long they took, and by whom.
NOT_THE_PLAY = ("elapsed_s", "model", "models", "trajectory")


@pytest.fixture(scope="module")
def calls(tmp_path_factory) -> list[str]:
    return oracle_calls(tmp_path_factory.mktemp("oracle") / "run")


def human_request(out: Path, **fields) -> cb.RunRequest:
    return cb.RunRequest(out=out, models=["human"], selection=SELECTION,
                         conditions=["C0_blind"], **fields)


def the_play(result: dict) -> dict:
    return {k: v for k, v in result.items() if k not in NOT_THE_PLAY}


def decisions(folder: Path, result: dict) -> list[dict]:
    return json.loads((folder / result["trajectory"]).read_text())["planner_decisions"]


def test_a_c0_episode_played_by_a_person_equals_a_scripted_one(calls, tmp_path):
    desk = OracleDesk(calls)
    played = cb.run(human_request(tmp_path / "human"), desk=desk)[0]
    script = tmp_path / "replies.json"
    script.write_text(json.dumps(desk.reply_texts()))
    scripted = cb.run(cb.RunRequest(out=tmp_path / "scripted", models=[f"scripted:{script}"],
                                    selection=SELECTION, conditions=["C0_blind"]))[0]

    assert played["model"] == "human" and played["terminal_reason"] == "done"
    assert played["task_success"] == 1 and played["construct_score"] is not None
    usage, scripted_usage = played.pop("usage"), scripted.pop("usage")
    assert the_play(played) == the_play(scripted)
    think = usage.pop("model_latency_s")
    assert think == pytest.approx(0.5 * len(desk.asked))  # a person's latency: think time
    assert usage == {k: v for k, v in scripted_usage.items() if k != "model_latency_s"}
    assert usage["prompt_tokens"] == usage["completion_tokens"] == usage["cost_usd"] == 0
    first = decisions(tmp_path / "human", played)[0]
    assert first["model"] == "human" and first["latency_s"] == 0.5
    assert first["raw_output"] == desk.reply_texts()[0]


def test_a_person_in_a_d1_team_is_heard_by_the_teammates(calls, tmp_path):
    mine = [c for c in calls if c.partition("(")[2].startswith("agent_1")]
    desk = OracleDesk(mine, message="agent one, move {n}")
    script = tmp_path / "teammate.txt"
    script.write_text("REASON: I let my teammate work\nACTION: DONE\nMSG: fine")
    out = tmp_path / "team"
    request = cb.RunRequest(out=out, models=[f"scripted:{script}"],
                            agent_models={"agent_1": "human"}, selection=SELECTION,
                            conditions=["D1_blind"])
    result = cb.run(request, desk=desk)[0]

    assert result["models"] == {"agent_1": "human", "agent_2": f"scripted:{script}"}
    made = decisions(out, result)
    assert {(d["agent"], d["model"]) for d in made if d.get("prompt_hash")} == {
        ("agent_1", "human"), ("agent_2", f"scripted:{script}")}
    prompts = RunFolder(out).prompts(EpisodeKey(result["model"], "D1_blind", TASK))
    heard = [d for d in made if d["agent"] == "agent_2" and d.get("prompt_hash")]
    said = [d for d in made if d["agent"] == "agent_1" and d.get("message")]
    assert said and all(d["message"].startswith("agent one, move") for d in said)
    for spoken in said[:3]:
        later = next(d for d in heard if d["step_index"] > spoken["step_index"])
        assert f"agent_1: {spoken['message']}" in prompts[later["prompt_hash"]]
    lines = (out / answers_file(desk.asked[0].episode)).read_text().splitlines()
    assert len(lines) == len(desk.asked)
    assert json.loads(lines[0])["message"] == "agent one, move 1"


def test_an_answer_log_that_cannot_be_read_stops_the_run_naming_it(calls, tmp_path):
    """A run folder whose answer log is a folder (someone else's, damaged) stops the run
    with the run folder's one-line error before the person is asked, and records no
    episode as something else."""
    out = tmp_path / "run"
    log = out / answers_file(f"human/C0_blind/{TASK}")
    log.mkdir(parents=True)
    desk = OracleDesk(calls)
    with pytest.raises(RunFolderError, match=re.escape(f"{log}: unreadable (Is a directory)")):
        cb.run(human_request(out), desk=desk, resume=True)
    assert desk.asked == [] and list(RunFolder(out).results()) == []


def test_an_answer_that_cannot_be_logged_stops_the_run(calls, tmp_path, monkeypatch):
    """A full disk when a person's answer is logged stops the run (`RunFolderFailed`, with
    the resume command), not the seat's model failing: the answer would be asked again."""
    write = os.write

    def answer_log_full(fd, data):  # every other file still has room
        if os.readlink(f"/proc/self/fd/{fd}").endswith(HUMAN_ANSWERS):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return write(fd, data)

    monkeypatch.setattr(json_lines.os, "write", answer_log_full)
    out = tmp_path / "run"
    desk = OracleDesk(calls)
    with pytest.raises(RunFolderFailed, match=r"No space left on device.*--resume"):
        cb.run(human_request(out), desk=desk)
    monkeypatch.undo()
    assert len(desk.asked) == 1 and list(RunFolder(out).results()) == []


def test_an_answer_is_logged_and_replayed_for_the_same_decision_only(tmp_path):
    decision = Decision(id="human/C0_blind/T#team#1", episode="human/C0_blind/T", seat="team",
                        prompt="the prompt", menu=({"id": 3, "skill": "Wait", "call": "W()"},))
    asked: list[Decision] = []

    class Person:
        async def ask(self, decision: Decision) -> Answer:
            asked.append(decision)
            return Answer(3, reason="why", message="hello", think_s=1.25)

    async def ask(decision: Decision) -> Answer:
        return await LoggedDesk(Person(), RunFolder(tmp_path)).ask(decision)

    first = asyncio.run(ask(decision))
    log = tmp_path / "episodes/human/C0_blind/T" / HUMAN_ANSWERS
    with log.open("a") as f:
        f.write('{"decision": "human/C0_blind/T#team#2", "action')  # a kill in mid-write
    assert asyncio.run(ask(decision)) == first and len(asked) == 1  # replayed
    changed = Decision(**{**decision.__dict__, "prompt": "a teammate chose otherwise"})
    asyncio.run(ask(changed))  # another situation under the same id: asked again
    assert len(asked) == 2
    lines = [json.loads(line) for line in log.read_text().splitlines()]
    assert [line["decision"] for line in lines] == [decision.id, decision.id]
    assert lines[0]["call"] == "W()" and lines[0]["think_s"] == 1.25
    assert "token" not in log.read_text()


def test_a_run_with_human_seats_needs_a_desk_and_the_local_executor(tmp_path):
    with pytest.raises(RequestError, match="human seats need a player"):
        cb.run(human_request(tmp_path / "no-desk"))
    with pytest.raises(RequestError, match="human seats need the local executor"):
        cb.run(human_request(tmp_path / "ray", execution={"executor": "ray"}),
               desk=OracleDesk([]))
    assert not (tmp_path / "no-desk" / "run.json").exists()


def test_human_is_a_built_in_without_keys_or_preflight(monkeypatch):
    for variable in ("OPENAI_API_KEY", "ANTHROPIC_API_KEY"):
        monkeypatch.delenv(variable, raising=False)
    pool = ModelPool()
    pool.validate("human")
    preflight(pool, ["human"], ["image", "blind"])  # calls nothing
    with pytest.raises(ModelConfigError, match="takes no argument"):
        pool.validate("human:alice")
    with pytest.raises(ModelConfigError, match="needs a player"):
        pool.client("human", episode="e", agent=None)


def test_a_request_without_a_menu_is_not_put_to_a_person():
    from cocobench_agents.models import ModelError, ModelRequest
    from cocobench_agents.models.human import HumanClient

    client = HumanClient(OracleDesk([]), episode="e")
    with pytest.raises(ModelError, match="chooses from a menu"):  # a leader's free text
        asyncio.run(client.complete(ModelRequest(prompt="write one line per robot")))


def test_a_human_episode_has_no_default_timeout():
    limits = cb.RunRequest(out="x").limits
    assert limits.episode_timeout is None
    assert limits.episode_timeout_s(human=True) is None
    assert limits.episode_timeout_s(human=False) == 7200
    given = cb.RunRequest(out="x", limits={"episode_timeout": 60}).limits
    assert given.episode_timeout_s(human=True) == given.episode_timeout_s(human=False) == 60
    assert cb.RunRequest(out="x", limits={"episode_timeout": 0}).limits.episode_timeout_s(
        human=False) is None


@pytest.mark.slow
def test_a_killed_play_resumes_at_its_pending_decision(calls, tmp_path):
    stop_at = 7
    request = human_request(tmp_path / "killed")
    (tmp_path / "request.json").write_text(request.model_dump_json())
    (tmp_path / "calls.json").write_text(json.dumps(calls))
    pending = tmp_path / "pending"
    driver = subprocess.Popen(
        [sys.executable, str(ROOT / "tests/human/play_driver.py"), str(tmp_path / "request.json"),
         str(tmp_path / "calls.json"), str(stop_at), str(pending)],
        cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT)}, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 120
    while not pending.exists():
        assert driver.poll() is None, driver.stderr.read().decode()
        assert time.monotonic() < deadline, "the driver never reached its pending decision"
        time.sleep(0.05)
    driver.kill()  # SIGKILL, while the person is thinking
    driver.wait()
    log = tmp_path / "killed" / answers_file(pending.read_text().partition("#")[0])
    assert len(log.read_text().splitlines()) == stop_at - 1

    desk = OracleDesk(calls)
    resumed = cb.run(request, resume=True, desk=desk)[0]
    assert desk.asked[0].id == pending.read_text()  # none of the earlier decisions again
    whole_desk = OracleDesk(calls)
    whole = cb.run(human_request(tmp_path / "whole"), desk=whole_desk)[0]
    assert len(desk.asked) == len(whole_desk.asked) - (stop_at - 1)
    assert the_play(resumed) == the_play(whole)
    assert decisions(tmp_path / "killed", resumed) == decisions(tmp_path / "whole", whole)
    assert len(log.read_text().splitlines()) == len(whole_desk.asked)  # kept, no repeats

    again = OracleDesk(calls)
    cb.run(request, resume=True, desk=again)
    assert again.asked == []  # a finished episode never asks again
    assert len(cb.run(request, resume=True)) == 1  # nor needs a player
