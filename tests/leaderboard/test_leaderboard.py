"""The leaderboard of three bundles, two that verify and one tampered with: the two are
ranked, the third is marked and not ranked; in Chromium the columns sort, the rows link to
their episodes' pages, and nothing is requested from outside the site."""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

import pytest

from cocobench_agents.cli import main
from cocobench_agents.leaderboard import build_leaderboard
from cocobench_agents.leaderboard.site import COLUMNS
from cocobench_agents.verify import pack

#: Two models that verify, and a third run whose result line is edited before packing (the
#: bundle's hashes match: only the replay tells).
MODELS = {"greedy": "greedy", "random": "random:1", "tampered": "random:2"}


@pytest.fixture(scope="module")
def bundles(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    home = tmp_path_factory.mktemp("leaderboard")
    out = {}
    for name, model in MODELS.items():
        run = home / name
        assert main(["run", "--suite", "demo", "--model", model, "--conditions",
                     "C0_blind", "--out", str(run)]) == 0
        if name == "tampered":
            lines = [json.loads(x) for x in (run / "results.jsonl").read_text().splitlines()]
            lines[0]["task_success"] = 1
            (run / "results.jsonl").write_text("".join(json.dumps(x) + "\n" for x in lines))
        pack(run, home / f"{name}.cocobench.tar.gz")
        out[name] = home / f"{name}.cocobench.tar.gz"
    return out


@pytest.fixture(scope="module")
def site(bundles: dict[str, Path], tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("site") / "site"
    assert main(["leaderboard", *map(str, bundles.values()), "--out", str(out)]) == 0
    return out


def records(site: Path) -> list[dict[str, Any]]:
    return json.loads((site / "leaderboard.json").read_text())


def test_two_verified_bundles_are_ranked_and_the_tampered_one_is_marked(site: Path) -> None:
    rows = {r["model"]: r for r in records(site)}
    assert set(rows) == {"greedy", "random:1", "random:2"}
    assert rows["greedy"]["badge"] == rows["random:1"]["badge"] == "verified"
    assert sorted([rows["greedy"]["rank"], rows["random:1"]["rank"]]) == [1, 2]
    tampered = rows["random:2"]
    assert tampered["badge"] == "mismatch" and tampered["rank"] is None
    assert "task_success" in tampered["why"]
    for row in rows.values():
        assert row["condition"] == "C0_blind" and row["planner"] == "centralized"
        assert row["prompt_suite"] == "cocobench-v1@1.0" and row["settings"] == []
        assert row["episodes"] == 4 and row["tokens"] == 0.0 and row["dollars"] == 0.0
        sr = row["sr"]
        assert sr["lo"] <= sr["value"] <= sr["hi"] and sr["n"] == 4
        assert set(row["cs_dims"]) == {"D1", "D2", "D3", "D4"}
        assert row["pass_k"] is None  # one epoch
        assert (site / row["pages"]).is_file()


def test_labelled_and_refused_rows_are_not_ranked(tmp_path: Path) -> None:
    run = tmp_path / "short"
    assert main(["run", "--suite", "demo", "--model", "greedy", "--conditions", "C0_blind",
                 "--max-steps", "3", "--out", str(run)]) == 0
    short = pack(run, tmp_path / "short.cocobench.tar.gz")
    assert short["non_reference"] == {"max_steps": 3}
    epochs = tmp_path / "epochs"
    assert main(["run", "--suite", "demo", "--model", "random:4", "--conditions", "C0_blind",
                 "--epochs", "2", "--out", str(epochs)]) == 0
    board = build_leaderboard([tmp_path / "short.cocobench.tar.gz", epochs],
                              tmp_path / "site", jobs=1)
    rows = {r.model: r for r in board.rows}
    assert rows["greedy"].badge == "verified" and rows["greedy"].settings == ["max_steps=3"]
    assert rows["greedy"].rank is None  # labelled: shown, never mixed into the ranking
    assert rows["random:4"].rank == 1 and rows["random:4"].pass_k[0] == 2
    page = (tmp_path / "site" / "index.html").read_text()
    assert "verified · labelled" in page and "max_steps=3" in page


def test_an_existing_site_folder_is_refused(bundles: dict[str, Path], tmp_path: Path,
                                            capsys) -> None:
    (tmp_path / "site").mkdir()
    (tmp_path / "site" / "keep.txt").write_text("mine")
    assert main(["leaderboard", str(bundles["greedy"]), "--out", str(tmp_path / "site")]) == 2
    assert "not empty" in capsys.readouterr().err
    assert (tmp_path / "site" / "keep.txt").read_text() == "mine"


@pytest.mark.slow
@pytest.mark.needs_browser
def test_in_chromium_columns_sort_rows_link_and_nothing_external(site: Path,
                                                                  tmp_path: Path) -> None:
    from playwright.sync_api import expect

    from tests.viewer.browser import chromium_page, screenshots_folder

    requested: list[str] = []
    with chromium_page(1600, 500) as page:
        page.on("request", lambda request: requested.append(request.url))
        page.goto((site / "index.html").as_uri())
        rows = page.locator("#leaderboard tbody tr")
        expect(rows).to_have_count(3)
        expect(page.locator("span.badge.mismatch")).to_have_count(1)
        sr = page.locator('th[data-key="sr"]')
        sr.click()
        expect(sr).to_have_attribute("aria-sort", "descending")
        column = 1 + [key for key, *_ in COLUMNS].index("sr")
        values = page.locator(f"#leaderboard tbody td:nth-child({column})").evaluate_all(
            "cells => cells.map(c => Number(c.dataset.value))")
        assert values == sorted(values, reverse=True)
        sr.click()
        expect(sr).to_have_attribute("aria-sort", "ascending")
        values = page.locator(f"#leaderboard tbody td:nth-child({column})").evaluate_all(
            "cells => cells.map(c => Number(c.dataset.value))")
        assert values == sorted(values)
        page.locator('th[data-key="model"]').click()
        models = page.locator("#leaderboard tbody td:nth-child(3)").all_inner_texts()
        assert models == sorted(models, reverse=True)
        page.screenshot(path=screenshots_folder(tmp_path) / "leaderboard.png", full_page=True)
        page.locator("#leaderboard tbody tr", has_text="random:2").locator("a").click()
        expect(page.locator("table.episodes tbody tr")).to_have_count(4)
        assert page.url.startswith(site.as_uri()) and "/runs/" in page.url
    assert requested and all(url.startswith("file://") for url in requested), requested


def test_the_site_works_from_any_folder(site: Path, tmp_path: Path) -> None:
    """Every link of the index is relative and leads to a file of the site."""
    import re

    moved = tmp_path / "elsewhere"
    shutil.copytree(site, moved)
    page = (moved / "index.html").read_text()
    links = re.findall(r'(?:href|src)="([^"]+)"', page)
    assert links and all("://" not in link and not link.startswith("/") for link in links)
    assert all((moved / link).is_file() for link in links)
