"""The play page for a person, in Debian's headless chromium (Playwright): a click answers
only the decision the person saw (double clicks, presses begun before the menu was drawn,
stale tabs, a dead token), the seats are named on the page and in the viewer, and the page's
aids (step numbers, the last action's result, focus, an announcement, drafts kept across a
reload)."""

from __future__ import annotations

import json
import re
import socket
from pathlib import Path
from typing import Any

import pytest
from playwright.sync_api import expect

from cocobench_agents.viewer.pages import Pages
from cocobench_agents.viewer.server import ViewerServer
from cocobench_agents.viewer.source import Catalog
from tests.play.played_run import DEMO, StartRun, answers_logged, result_lines
from tests.play.player import Player

pytestmark = [pytest.mark.slow, pytest.mark.needs_browser]

RUN_ARGS = ("--suite", "demo", "--task-id", DEMO)


def human_run(start_run: StartRun, out: Path, condition: str, *args: str) -> Any:
    return start_run("--model", "human", "--conditions", condition, *RUN_ARGS,
                     "--out", str(out), *args)


def button(page: Any, call: str) -> Any:
    return page.locator(f'#menu button[title="{call}"]')


def centre(locator: Any) -> tuple[float, float]:
    box = locator.bounding_box()
    return box["x"] + box["width"] / 2, box["y"] + box["height"] / 2


def next_decision(page: Any, after: str) -> str:
    """The id of the decision drawn after `after`, once its menu can be clicked."""
    expect(page.locator(f'#menu[data-decision="{after}"]')).to_have_count(0)
    return Player(page).pending()


def answers_posted(page: Any) -> list[dict]:
    """The answers `page` sends from now on (the bodies of its POSTs)."""
    posted: list[dict] = []
    page.on("request", lambda request: posted.append(json.loads(request.post_data))
            if request.url.endswith("/play/api/answer") else None)
    return posted


def hold_updates(page: Any) -> list[Any]:
    """Hold `page`'s waiting state requests (the page shows what it drew last, as a slow
    network would) until `release` continues them."""
    held: list[Any] = []
    page.route("**/play/api/state?after=*", lambda route: held.append(route))
    return held


def release(page: Any, held: list[Any]) -> None:
    """Let `page`'s held state request through (it waits on one at a time: the latest; an
    earlier one ended with its page's reload)."""
    held[-1].continue_()
    page.unroute("**/play/api/state?after=*")


def in_view(page: Any, locator: Any) -> bool:
    box = locator.bounding_box()
    return box is not None and box["y"] >= 0 and box["y"] + box["height"] <= (
        page.viewport_size["height"])


def logged(out: Path) -> list[tuple[str, int | None]]:
    return [(a["decision"], a["action_id"]) for a in answers_logged(out)]


def chosen_id(page: Any, call: str) -> int:
    return int(button(page, call).inner_text().split(":")[0])


def second_click_of_a_double_click(page: Any) -> None:
    """What the system sends for the second click of a double click (click count 2), where
    the mouse is."""
    page.mouse.down(click_count=2)
    page.mouse.up(click_count=2)


def on_top_is_a_menu_button(page: Any, x: float, y: float, decision: str) -> bool:
    return page.evaluate(
        "([x, y, id]) => !!document.elementFromPoint(x, y)"
        ".closest(`#menu[data-decision='${id}'] button`)", [x, y, decision])


def test_a_double_click_records_one_decision(start_run: StartRun, page: Any,
                                             calls: list[str], tmp_path: Path) -> None:
    out = tmp_path / "human"
    run = human_run(start_run, out, "C0_blind")
    page.goto(run.url)
    posted = answers_posted(page)
    first = Player(page).pending()
    # DONE and the reason are on screen above a menu of 32 buttons
    for control in ("#done", "#reason", "#menu h3"):
        assert in_view(page, page.locator(control).first), control
    expect(page.locator("#menu h3")).to_have_text(["agent_1", "agent_2"])
    ids = [chosen_id(page, calls[0])]
    button(page, calls[0]).dblclick()
    second = next_decision(page, first)
    assert logged(out) == [(first, ids[0])]  # one line, and the next decision is open

    # The reported case: the second click lands after the next menu was drawn, on the
    # button now in the same place.
    ids.append(chosen_id(page, calls[1]))
    x, y = centre(button(page, calls[1]))
    page.mouse.click(x, y)
    third = next_decision(page, second)
    assert on_top_is_a_menu_button(page, x, y, third)
    second_click_of_a_double_click(page)
    ids.append(chosen_id(page, calls[2]))
    Player(page).choose(calls[2])  # the person's own choice for the third decision
    assert logged(out) == [(first, ids[0]), (second, ids[1]), (third, ids[2])]
    assert [p["decision"] for p in posted] == [first, second, third]


def test_in_an_all_human_d1_team_a_double_click_never_answers_the_other_seat(
        start_run: StartRun, page: Any, tmp_path: Path) -> None:
    out = tmp_path / "human"
    run = human_run(start_run, out, "D1_blind")
    page.goto(run.url)
    first = Player(page).pending()
    assert first.endswith("#agent_1#1")
    target = page.locator("#menu button").nth(7)
    chosen = int(target.inner_text().split(":")[0])
    x, y = centre(target)
    page.mouse.click(x, y)
    second = next_decision(page, first)
    assert second.endswith("#agent_2#1")
    assert on_top_is_a_menu_button(page, x, y, second)  # agent_2's button, same place
    second_click_of_a_double_click(page)
    Player(page).choose(None)  # agent_2's own answer: DONE
    next_decision(page, second)
    assert logged(out) == [(first, chosen), (second, None)]


def test_a_press_begun_before_the_menu_was_drawn_answers_nothing(
        start_run: StartRun, page: Any, calls: list[str], tmp_path: Path) -> None:
    """On DONE, the one control that outlives a decision (the menu's buttons are drawn anew,
    so a press on the old ones never ends on a new one): pressed while the answered
    decision's controls are off, released once the next decision has turned them on."""
    out = tmp_path / "human"
    run = human_run(start_run, out, "C0_blind")
    page.goto(run.url)
    Player(page).pending()
    held = hold_updates(page)
    page.reload()  # its first state comes at once, the next ones wait in `held`
    first = Player(page).pending()
    ids = [chosen_id(page, calls[0])]
    page.keyboard.type(str(ids[0]))
    page.keyboard.press("Enter")
    expect(page.locator("#sent")).to_contain_text("Sent")
    page.mouse.move(*centre(page.locator("#done")))
    page.mouse.down()  # on the answered decision's (disabled) DONE …
    release(page, held)
    second = next_decision(page, first)
    page.mouse.up()  # … released once the next decision is drawn
    ids.append(chosen_id(page, calls[1]))
    Player(page).choose(calls[1], keyboard=True)
    assert logged(out) == [(first, ids[0]), (second, ids[1])]


def test_a_click_in_a_stale_tab_answers_nothing(start_run: StartRun, page: Any,
                                                calls: list[str], tmp_path: Path) -> None:
    out = tmp_path / "human"
    run = human_run(start_run, out, "C0_blind")
    page.goto(run.url)
    first = Player(page).pending()
    stale = page.context.new_page()
    held = hold_updates(stale)
    stale.goto(run.url)
    assert Player(stale).pending() == first
    ids = [chosen_id(page, calls[0])]
    Player(page).choose(calls[0])  # answered in the first tab; the stale one still shows it
    assert stale.locator("#menu").get_attribute("data-decision") == first
    stale.locator("#menu button").first.click()
    expect(stale.locator("#sent")).to_contain_text("Not taken")
    expect(stale.locator("#sent")).to_contain_text("not waiting for an answer")
    expect(stale.locator("#menu button").first).to_be_disabled()
    assert logged(out) == [(first, ids[0])]
    release(stale, held)
    assert next_decision(stale, first) == Player(page).pending()  # it catches up


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def test_a_tab_whose_token_died_says_so_and_disables_its_menu(
        start_run: StartRun, page: Any, calls: list[str], tmp_path: Path) -> None:
    out = tmp_path / "human"
    port = str(free_port())
    run = human_run(start_run, out, "C0_blind", "--port", port)
    page.goto(run.url)
    Player(page).choose(calls[0])
    Player(page).pending()
    run.kill()
    expect(page.locator("#problem")).to_contain_text("not answering")
    expect(page.locator("#menu button").first).to_be_disabled()
    expect(page.locator("#done")).to_be_disabled()

    resumed = human_run(start_run, out, "C0_blind", "--port", port, "--resume")
    assert resumed.port == int(port) and resumed.token != run.token
    expect(page.locator("#problem")).to_contain_text("earlier start of cocobench run")
    expect(page.locator("#menu button").first).to_be_disabled()
    assert len(answers_logged(out)) == 1
    page.goto(resumed.url)  # the new address plays on
    Player(page).choose(calls[1])
    assert len(answers_logged(out)) == 2


def test_the_page_names_the_seats_and_helps_a_person_play(
        start_run: StartRun, page: Any, calls: list[str], tmp_path: Path,
        shots: Path) -> None:
    mine = [c for c in calls if c.partition("(")[2].startswith("agent_1")]
    out = tmp_path / "team"
    run = start_run("--model", "greedy", "--agent-model", "agent_1=human", "--conditions",
                    "D1_blind", *RUN_ARGS, "--max-steps", "4", "--out", str(out))
    page.goto(run.url)
    player = Player(page)
    first = player.pending()
    expect(page.locator("#seats")).to_have_text("agent_1: you (human) · agent_2: greedy")
    # the agent is named once, above its buttons
    expect(page.locator("#menu h3")).to_have_text(["agent_1"])
    assert not any("agent_" in label for label in player.menu())
    # focus on the menu, and the decision announced
    assert page.evaluate("document.activeElement.closest('#menu') !== null")
    expect(page.locator("#announce")).to_have_text(
        re.compile(r"^agent_1: your decision, step 1, \d+ actions\.$"))
    expect(page.locator("#last-action")).to_be_hidden()  # nothing done yet
    # a half-typed reason and message survive a reload
    page.fill("#reason", "the book is mine")
    page.fill("#message", "I take the Book")
    page.reload()
    assert player.pending() == first
    expect(page.locator("#reason")).to_have_value("the book is mine")
    expect(page.locator("#message")).to_have_value("I take the Book")
    player.choose(mine[0], message="I take the Book")

    player.pending()
    assert page.evaluate("document.activeElement.closest('#menu') !== null")
    step = landed_step(page, mine[0])
    result = f"step {step}: {mine[0]} -> ok"
    expect(page.locator("#last-action")).to_have_text(f"Your last action — {result}")
    expect(page.locator(".part-history pre")).to_contain_text(result)
    expect(page.locator("#announce")).to_contain_text(f"Your last action: {result}.")
    expect(page.locator("#reason")).to_have_value("")  # a new decision, a new reason
    page.screenshot(path=shots / "play-person.png")
    done_until_the_end(page, player)
    assert run.wait() == 0

    (result_line,) = result_lines(out)
    trajectory = json.loads((out / result_line["trajectory"]).read_text())
    assert step == next(i["step_index"] for i in trajectory["trajectory"]
                        if i.get("label") == mine[0])
    check_viewer(page, out, shots)


def done_until_the_end(page: Any, player: Player) -> None:
    """Answer DONE to every decision (the seat is asked each round while its teammate plays
    on) until the run ends."""
    ended = page.locator("#ended:not([hidden])")
    while True:
        page.locator("#ended:not([hidden]), #menu[data-decision] button:enabled").first.wait_for()
        if ended.count():
            return
        player.choose(None)


def landed_step(page: Any, call: str) -> int:
    """The step number the page gives the seat's last action."""
    expect(page.locator("#last-action")).to_contain_text(call)
    return int(re.search(r"step (\d+):", page.locator("#last-action").inner_text())[1])


def check_viewer(page: Any, out: Path, shots: Path) -> None:
    """`cocobench view` of the human–AI run names each seat's model where it names models."""
    team = "agent_1: human · agent_2: greedy"
    with ViewerServer(Pages.create(Catalog([out]), live=False), 0) as server:
        page.goto(server.url)
        row = page.locator("table.episodes tbody tr")
        expect(row).to_have_count(1)
        expect(row.locator("td").nth(1)).to_have_text(team)
        expect(page.locator("table.summary tbody td").first).to_have_text(team)
        row.locator("td.instance a").first.click()
        expect(page.locator("p.subtitle")).to_contain_text(f"{team} · D1_blind")
        expect(page.locator("ul.team")).to_contain_text("agent_1: human")
        expect(page.locator("ul.team")).to_contain_text("agent_2: greedy")
        heads = page.locator(".entry-head").all_inner_texts()
        assert any("agent_1: human" in head for head in heads)
        assert any("agent_2: greedy" in head for head in heads)
        assert all(re.search(r"agent_[12]: (human|greedy)", head) for head in heads)
        page.screenshot(path=shots / "viewer-human-ai.png")
