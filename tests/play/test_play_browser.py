"""A person plays `cocobench run --model human` in a real headless chromium (Debian's, driven
by Playwright): by clicking and by the keyboard, in a human–AI D1 team, across reloads and
tabs, and across a kill -9 of the run. Screenshots are kept under
$COCOBENCH_VIEWER_SCREENSHOTS (else the test's tmp dir)."""

from __future__ import annotations

import json
import urllib.error
import urllib.request
from pathlib import Path
from typing import Any

import pytest
from playwright.sync_api import expect

from cocobench_agents.play.server import TOKEN_HEADER
from cocobench_agents.runfolder.episode_key import EpisodeKey
from cocobench_agents.runfolder.folder import RunFolder
from tests.play.played_run import (
    DEMO,
    PlayedRun,
    StartRun,
    answers_logged,
    assert_token_nowhere,
    result_lines,
    scripted_result,
    the_play,
)
from tests.play.player import Player

pytestmark = [pytest.mark.slow, pytest.mark.needs_browser]

SELECTION = {"sources": ["demo"], "task_ids": [DEMO]}
RUN_ARGS = ("--suite", "demo", "--task-id", DEMO)


def test_a_c0_episode_played_by_clicking_equals_a_scripted_one(
        start_run: StartRun, page: Any, calls: list[str], tmp_path: Path, shots: Path) -> None:
    out = tmp_path / "human"
    run = start_run("--model", "human", "--conditions", "C0_blind", *RUN_ARGS, "--out", str(out))
    page.goto(run.url)
    player = Player(page)
    expect(page.locator(".part-goal")).to_contain_text("Put the Book in the Shelf")
    page.screenshot(path=shots / "play-c0.png")
    for n, call in enumerate([*calls, None]):
        player.choose(call, keyboard=n % 3 == 1)  # every third by the keyboard
    expect(page.locator("#ended")).to_contain_text("The run has ended")
    expect(page.locator("#outcomes tbody tr")).to_have_count(1)
    assert run.wait() == 0

    (played,) = result_lines(out)
    scripted = scripted_result(tmp_path / "scripted", player.replies(), selection=SELECTION,
                               conditions=["C0_blind"])
    assert played["model"] == "human" and played["task_success"] == 1
    assert played["terminal_reason"] == "done" and None in player.chosen
    assert the_play(played) == the_play(scripted)
    outcome = page.locator("#outcomes tbody tr").inner_text()
    assert f"{played['construct_score']:.2f}" in outcome and "done" in outcome
    assert "human" in "".join(run.stdout)  # the summary's row
    assert_token_nowhere(out, run.token)


def test_a_person_in_a_d1_team_talks_with_scripted_teammates(
        start_run: StartRun, page: Any, calls: list[str], tmp_path: Path, shots: Path) -> None:
    mine = [c for c in calls if c.partition("(")[2].startswith("agent_1")]
    script = tmp_path / "teammate.json"
    # the teammate's part of the oracle's plan (a message lands with a landed call only)
    script.write_text(json.dumps([f"REASON: my part\nACTION: {action}\nMSG: agent two, step {n}"
                                  for n, action in enumerate((26, 38, 25, 39), 1)]))
    out = tmp_path / "team"
    run = start_run("--model", f"scripted:{script}", "--agent-model", "agent_1=human",
                    "--conditions", "D1_image", *RUN_ARGS, "--out", str(out))
    page.goto(run.url)
    player = Player(page)
    expect(page.locator("#message-field")).to_be_visible()
    expect(page.locator("#frames img")).to_have_count(1)  # image mode: the seat's own view
    player.choose(mine[0], message="I take the Book")
    # the teammate's word reaches the person, and the person's reaches the teammate
    expect(page.locator(".part-messages")).to_contain_text("agent_2: agent two, step 1")
    page.fill("#reason", "the shelf is next")
    page.screenshot(path=shots / "play-d1.png")
    for n, call in enumerate([*mine[1:], None]):
        player.choose(call, message=f"then move {n + 2}")
    assert run.wait() == 0

    (result,) = result_lines(out)
    assert result["task_success"] == 1  # the person and the script, together
    assert result["models"] == {"agent_1": "human", "agent_2": f"scripted:{script}"}
    made = json.loads((out / result["trajectory"]).read_text())["planner_decisions"]
    assert {(d["agent"], d["model"]) for d in made if d.get("prompt_hash")} == {
        ("agent_1", "human"), ("agent_2", f"scripted:{script}")}
    prompts = RunFolder(out).prompts(EpisodeKey(result["model"], "D1_image", DEMO))
    heard = [prompts[d["prompt_hash"]] for d in made
             if d["agent"] == "agent_2" and d.get("prompt_hash")]
    assert "agent_1: I take the Book" not in heard[0]
    assert "agent_1: I take the Book" in heard[1]  # the teammate's next prompt
    assert [a["message"] for a in answers_logged(out)][:2] == ["I take the Book", "then move 2"]
    assert_token_nowhere(out, run.token)


def post_answer(run: PlayedRun, body: dict) -> int:
    request = urllib.request.Request(
        f"http://127.0.0.1:{run.port}/play/api/answer", data=json.dumps(body).encode(),
        headers={TOKEN_HEADER: run.token, "Content-Type": "application/json"}, method="POST")
    try:
        with urllib.request.urlopen(request, timeout=30) as response:
            return response.status
    except urllib.error.HTTPError as exc:
        return exc.code


def test_reload_and_a_second_tab_show_the_pending_decision_once(
        start_run: StartRun, page: Any, calls: list[str], tmp_path: Path) -> None:
    out = tmp_path / "human"
    run = start_run("--model", "human", "--conditions", "C0_blind", *RUN_ARGS, "--out", str(out))
    page.goto(run.url)
    player = Player(page)
    player.choose(calls[0])
    first, menu = player.pending(), player.menu()
    page.reload()
    assert (player.pending(), player.menu()) == (first, menu)
    other = Player(page.context.new_page())
    other.page.goto(run.url)
    assert (other.pending(), other.menu()) == (first, menu)

    player.choose(calls[1])  # answered in the first tab …
    answered = len(answers_logged(out))
    # … the second tab moves on by itself, and a second answer to it is refused
    expect(other.page.locator(f'#menu[data-decision="{first}"]')).to_have_count(0)
    assert post_answer(run, {"decision": first, "action_id": player.chosen[-1]}) == 409
    assert len(answers_logged(out)) == answered

    for call in [*calls[2:], None]:
        other.choose(call)
    assert run.wait() == 0
    asked = [a["decision"].rpartition("#")[2] for a in answers_logged(out)]
    assert asked == [str(n) for n in range(1, len(calls) + 2)]  # each once, in order


def test_a_killed_run_resumes_at_the_pending_decision(
        start_run: StartRun, page: Any, calls: list[str], tmp_path: Path) -> None:
    out = tmp_path / "human"
    args = ("--model", "human", "--conditions", "C0_blind", *RUN_ARGS, "--out", str(out))
    run = start_run(*args)
    page.goto(run.url)
    player = Player(page)
    for call in calls[:4]:
        player.choose(call)
    pending = player.pending()
    run.kill()  # kill -9 with the fifth decision on the page
    assert not list(out.rglob("trajectory.json"))  # the episode did not end
    assert len(answers_logged(out)) == 4

    resumed = start_run(*args, "--resume")
    page.goto(resumed.url)
    assert player.pending() == pending  # not the first: the four answers are kept
    for call in [*calls[4:], None]:
        player.choose(call)
    assert resumed.wait() == 0

    (played,) = result_lines(out)
    scripted = scripted_result(tmp_path / "scripted", player.replies(), selection=SELECTION,
                               conditions=["C0_blind"])
    assert the_play(played) == the_play(scripted)  # as an uninterrupted play
    assert len(answers_logged(out)) == len(calls) + 1  # each decision answered once


def test_the_page_moves_on_to_the_next_episode_and_says_when_the_run_ends(
        start_run: StartRun, page: Any, tmp_path: Path) -> None:
    run = start_run("--model", "human", "--conditions", "C0_blind", *RUN_ARGS, "--epochs", "2",
                    "--out", str(tmp_path / "human"))
    page.goto(run.url)
    player = Player(page)
    expect(page.locator("#run-status")).to_have_text("episode 1 of 2")
    player.choose(None)
    expect(page.locator("#outcomes tbody tr")).to_have_count(1)
    expect(page.locator("#last-outcome")).to_contain_text("Episode finished")
    expect(page.locator("#run-status")).to_have_text("episode 2 of 2")  # by itself
    player.choose(None)
    expect(page.locator("#ended")).to_contain_text("The run has ended")
    expect(page.locator("#outcomes tbody tr")).to_have_count(2)
    expect(page.locator("#choose")).to_be_hidden()
    assert run.wait() == 0
