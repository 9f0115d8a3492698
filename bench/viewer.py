"""Viewer performance: the runs page of a 5,000-episode run folder in headless chromium.

Makes a real run with `cocobench run --model greedy` (8 episodes), repeats its result lines
as further epochs up to --episodes lines, serves the folder with the live viewer on
127.0.0.1 and loads the runs page --loads times in Debian's headless chromium (Playwright),
printing the median time to the load event with every row in the table (aim: < 2 s), the
server's render time, and the incremental refresh after 100 appended lines.

Usage: python bench/viewer.py [--episodes 5000] [--loads 5]
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from cocobench_agents.cli import main
from cocobench_agents.viewer.pages import Pages
from cocobench_agents.viewer.server import ViewerServer
from cocobench_agents.viewer.source import Catalog
from tests.viewer.browser import chromium_page, why_unavailable

TASKS = ("A_D1__EmbKitchen05__store_groceries_seed0", "A_D2__EmbKitchen03__stock_cabinet_seed0",
         "K_D3__EmbKitchen01__prepare_food_3agent_seed0",
         "C_D4__EmbBathroom02__relay_items_3agent_seed0")


def make_run(out: Path, episodes: int) -> None:
    args = ["run", "--model", "greedy", "--conditions", "C0_image,D1_blind", "--out", str(out)]
    for task in TASKS:
        args += ["--task-id", task]
    assert main(args) == 0
    lines = (out / "results.jsonl").read_text().splitlines()
    with open(out / "results.jsonl", "a") as f:
        for n in range(len(lines), episodes):
            record = json.loads(lines[n % len(lines)])
            f.write(json.dumps(record | {"epoch": n // len(lines)}) + "\n")


def main_bench() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--episodes", type=int, default=5000)
    parser.add_argument("--loads", type=int, default=5)
    options = parser.parse_args()
    if why_unavailable():
        sys.exit(f"cannot run: {why_unavailable()}")
    with tempfile.TemporaryDirectory() as tmp:
        run = Path(tmp) / "run"
        make_run(run, options.episodes)
        started = time.perf_counter()
        catalog = Catalog([run])
        print(f"read {options.episodes} result lines: {time.perf_counter() - started:.2f} s")
        pages = Pages.create(catalog, live=True)
        renders = []
        for _ in range(options.loads):
            started = time.perf_counter()
            html = pages.runs()
            renders.append(time.perf_counter() - started)
        print(f"render runs page ({len(html) / 1e6:.1f} MB): median "
              f"{statistics.median(renders):.2f} s")
        line = (run / "results.jsonl").read_text().splitlines()[0]
        with open(run / "results.jsonl", "a") as f:
            for n in range(100):
                f.write(json.dumps(json.loads(line) | {"epoch": 10_000 + n}) + "\n")
        started = time.perf_counter()
        catalog.refresh()
        print(f"refresh after 100 appended lines: {1000 * (time.perf_counter() - started):.1f} ms")
        loads = []
        with ViewerServer(pages, 0) as server, chromium_page() as page:
            for _ in range(options.loads):
                started = time.perf_counter()
                page.goto(server.url, wait_until="load")
                shown = page.locator("table.episodes tbody tr").count()
                loads.append(time.perf_counter() - started)
                total = page.locator("#episode-count").inner_text()
        print(f"runs page in headless chromium ({total} episodes, first {shown} rows drawn): "
              f"median "
              f"{statistics.median(loads):.2f} s (aim < 2 s) over {options.loads} loads")


if __name__ == "__main__":
    main_bench()
