"""End to end in a real headless chromium: the live viewer and an export, as a person sees
them. Screenshots are kept under $COCOBENCH_VIEWER_SCREENSHOTS (else the test's tmp dir)."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from playwright.sync_api import expect

from cocobench_agents.cli import main
from cocobench_agents.runfolder.result_line import CS_NOTE
from cocobench_agents.viewer.pages import Pages
from cocobench_agents.viewer.server import ViewerServer
from cocobench_agents.viewer.source import Catalog

from .browser import chromium_page, screenshots_folder

pytestmark = [pytest.mark.slow, pytest.mark.needs_browser]


@pytest.fixture
def shots(tmp_path: Path) -> Path:
    return screenshots_folder(tmp_path)


@pytest.fixture
def live(run_copy: Path) -> Iterator[str]:
    with ViewerServer(Pages.create(Catalog([run_copy]), live=True), 0) as server:
        yield server.url


def results(run: Path) -> list[dict]:
    return [json.loads(line) for line in (run / "results.jsonl").read_text().splitlines()]


def check_site(page: Any, base: str, run: Path, shots: Path, tag: str) -> None:
    records = results(run)
    page.goto(base + "index.html")
    rows = page.locator("table.episodes tbody tr")
    expect(rows).to_have_count(len(records))
    listed = set(rows.evaluate_all("rs => rs.map(r => r.dataset.key)"))
    assert listed == {f"0/episodes/greedy/{r['condition']}/{r['task_id']}" for r in records}
    page.screenshot(path=shots / f"{tag}-runs.png", full_page=True)
    # a CS column's tooltip says why a failing team can score 1.00
    expect(page.locator('th[data-key="cs"]')).to_have_attribute("title", f"sort. {CS_NOTE}")
    page.select_option('select[data-filter="dim"]', "D4")  # the filters work in the page
    expect(page.locator("table.episodes tbody tr")).to_have_count(2)
    page.select_option('select[data-filter="dim"]', "")
    page.locator('th[data-key="steps"]').click()  # sorting numerically
    steps = [int(t) for t in page.locator("tbody tr td:nth-child(15)").all_inner_texts()]
    assert steps == sorted(steps)

    record = next(r for r in records if r["condition"] == "D1_blind" and r["dim"] == "D2")
    page.click(f'a[href$="greedy/D1_blind/{record["task_id"]}.html"]')  # the row's link
    expect(page.locator("li.entry.landed")).to_have_count(record["num_steps"])
    traj = json.loads((run / record["trajectory"]).read_text())
    replies = page.locator("div.reply pre").all_inner_texts()
    assert replies == [d["raw_output"] for d in traj["planner_decisions"]]
    assert page.locator("svg.gantt rect").count() == record["num_steps"]
    page.screenshot(path=shots / f"{tag}-episode.png", full_page=False)
    page.locator("#expand-prompts").click()
    assert page.locator("details.prompt[open]").count() == len(traj["planner_decisions"])

    page.goto(base + f"compare/{record['task_id']}.html")
    expect(page.locator("thead th:visible")).to_have_count(3)  # the steps and two episodes
    page.screenshot(path=shots / f"{tag}-compare.png", full_page=False)


def test_live_viewer_in_chromium(live: str, run_copy: Path, shots: Path) -> None:
    with chromium_page() as page:
        check_site(page, live, run_copy, shots, "live")
        page.goto(live)
        line = results(run_copy)[0] | {"epoch": 2, "terminal_reason": "appended-live"}
        with open(run_copy / "results.jsonl", "a") as f:
            f.write(json.dumps(line) + "\n")
        # the open page picks the new episode up by itself (it polls every 2 s)
        expect(page.locator("td", has_text="appended-live")).to_have_count(1, timeout=30_000)
        expect(page.locator("table.episodes tbody tr")).to_have_count(9)
        expect(page.locator("#episode-count")).to_have_text("9")


def test_export_in_chromium(fixed_run: Path, tmp_path: Path, shots: Path) -> None:
    out = tmp_path / "site"
    assert main(["view", str(fixed_run), "--export", str(out)]) == 0
    with chromium_page() as page:
        check_site(page, out.as_uri() + "/", fixed_run, shots, "export")
