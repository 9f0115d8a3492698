"""The viewer's timeline shows a strategy's own model calls (`ask`, a client used directly)
beside its decisions: each with its prompt, reply, answer and usage."""

from __future__ import annotations

import html as html_text
import json
import re
from pathlib import Path

import cocobench_agents as cb
from cocobench_agents.graphs.plugins import forget_user_planners
from cocobench_agents.viewer.pages import Pages
from cocobench_agents.viewer.source import Catalog

ROOT = Path(__file__).resolve().parents[2]
SEALED_BID = f"{ROOT / 'examples' / 'strategies' / 'sealed_bid.py'}:SEALED_BID"
G_D1 = "G_D1__DemoLivingRoom1__seed0"


def test_both_calls_of_a_round_are_on_the_episode_page(tmp_path: Path) -> None:
    """Round 1: both robots bid for the Book; each is asked its price (4 and 2); agent_2
    wins, agent_1 is outbid. The page shows the two bids and the two pricing calls."""
    script = tmp_path / "script.json"
    script.write_text(json.dumps({
        "agent_1": ["ACTION: 0", "REASON: far\nACTION: 4", "ACTION: DONE"],
        "agent_2": ["ACTION: 24", "REASON: close\nACTION: 2", "ACTION: DONE"]}))
    out = tmp_path / "run"
    forget_user_planners()
    try:
        cb.run(cb.RunRequest(out=out, models=[f"scripted:{script}"], planners=[SEALED_BID],
                             obs_modes=["blind"], max_steps=4,
                             selection={"sources": ["demo"], "task_ids": [G_D1]}))
    finally:
        forget_user_planners()
    pages = Pages.create(Catalog([out]), live=False)
    (episode,) = pages.catalog.episodes()
    page = html_text.unescape(pages.episode(episode))

    asks = re.findall(r'<span class="badge call"[^>]*>(.*?)</span>', page)
    assert asks == ["ask · pricing", "ask · pricing"]
    assert "Teammates also want to work on the Book this round" in page  # its prompt
    assert "REASON: far\nACTION: 4" in page and "REASON: close\nACTION: 2" in page
    assert "answer: 4" in page and "answer: 2" in page
    assert "outbid" in page  # agent_1's bid, which did not land
    assert "Find(agent_2, Book|+01.20|+00.55|-00.80)" in page  # agent_2's, which did
    assert "protocol failure" not in page.split("<h2>Timeline")[1].split("outbid")[0]
    (line,) = [json.loads(x) for x in (out / "results.jsonl").read_text().splitlines()]
    assert line["usage"]["model_calls"] == 6


def test_a_leaders_plan_is_a_decision_of_the_leader_not_a_failure(tmp_path: Path) -> None:
    """Leader–worker: the leader's reply each round is its plan, recorded with status
    ``plan``; the page shows it as the leader's decision, with its instruction to each
    robot, never as a protocol failure."""
    script = tmp_path / "script.json"
    script.write_text(json.dumps({
        "team": ["agent_1: find the Book\nagent_2: find the RemoteControl"],
        "agent_1": ["ACTION: 0", "ACTION: DONE"], "agent_2": ["ACTION: 26", "ACTION: DONE"]}))
    out = tmp_path / "run"
    cb.run(cb.RunRequest(out=out, models=[f"scripted:{script}"], planners=["leader-worker"],
                         obs_modes=["blind"], max_steps=2,
                         selection={"sources": ["demo"], "task_ids": [G_D1]}))
    pages = Pages.create(Catalog([out]), live=False)
    (episode,) = pages.catalog.episodes()
    page = html_text.unescape(pages.episode(episode)).split("<h2>Timeline")[1]

    assert "protocol failure" not in page
    assert re.findall(r'<span class="badge call"[^>]*>(.*?)</span>', page)[0] == "leader plan"
    assert "agent_1: find the Book; agent_2: find the RemoteControl" in page
