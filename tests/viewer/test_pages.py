"""The viewer's pages rendered from a real run folder: what they show, and how they degrade
when the folder lacks something."""

from __future__ import annotations

import gzip
import html as html_text
import json
import re
from pathlib import Path

import cocobench_agents as cb
from benchmark_adapter.metrics.steps import extract_steps
from cocobench_agents.cli import main
from cocobench_agents.runfolder.result_line import CS_NOTE
from cocobench_agents.runfolder.summary import LEGEND, summary_rows
from cocobench_agents.viewer.pages import Pages
from cocobench_agents.viewer.rows import COLUMNS
from cocobench_agents.viewer.source import Catalog
from cocobench_agents.viewer.timeline import NO_PROMPT
from tests.human.desks import OracleDesk
from tests.play.played_run import DEMO

from .conftest import TASKS


def results(run: Path) -> list[dict]:
    return [json.loads(line) for line in (run / "results.jsonl").read_text().splitlines()]


def listed(html: str) -> list[dict]:
    """The episode rows a runs page carries (its table is drawn from them in the page)."""
    data = re.search(r'<script type="application/json" id="rows-data">(.*?)</script>', html, re.S)
    return json.loads(data.group(1))["rows"]


def pages_of(*runs: Path, live: bool = True) -> Pages:
    return Pages.create(Catalog(list(runs)), live=live)


def test_runs_page_lists_every_episode_and_the_summary(fixed_run: Path) -> None:
    records = results(fixed_run)
    html = pages_of(fixed_run).runs()
    rows = listed(html)
    assert len(rows) == len(records) == 8
    assert {r["k"] for r in rows} == {f"0/episodes/greedy/{r['condition']}/{r['task_id']}"
                                      for r in records}
    assert all(r["h"] == f"episode/{r['k'][:2]}{r['k'][11:]}.html" for r in rows)
    for row in summary_rows(records):  # the harness's own summary table, cell by cell
        assert "".join(f"<td>{cell}</td>" for cell in row) in html
    for column in ("model", "condition", "arm", "cell", "dim", "family", "agents", "success",
                   "construct_status", "terminal", "errors"):
        assert f'data-filter="{column}"' in html
    assert 'data-live="true"' in html


def test_a_construct_score_is_explained_where_it_is_shown(fixed_run: Path) -> None:
    pages = pages_of(fixed_run)
    runs = html_text.unescape(pages.runs())
    tip = f'title="{CS_NOTE}"'
    assert "capped at 1" in CS_NOTE and "a team that fails can score 1.00" in CS_NOTE
    assert runs.count(f"<th {tip}>CS") == 5  # the summary's CS and CS_D1..D4 headers
    assert f'<th data-key="cs" title="sort. {CS_NOTE}">CS</th>' in runs  # the episodes
    assert f'<p class="caption">{LEGEND}</p>' in runs and CS_NOTE in LEGEND
    episode = next(e for e in pages.catalog.episodes() if e.record.get("construct_score")
                   is not None)
    assert f'<div class="big" {tip}>' in html_text.unescape(pages.episode(episode))
    compare = html_text.unescape(pages.compare(episode.key.task_id) or "")
    assert f"<span {tip}>CS " in compare


def test_episode_page_shows_every_landed_step_reply_and_prompt(fixed_run: Path) -> None:
    pages = pages_of(fixed_run)
    for episode in pages.catalog.episodes():
        traj = pages.catalog.runs[0].trajectory(episode)
        html = pages.episode(episode)
        steps = extract_steps(traj)
        assert len(steps) == episode.record["num_steps"]
        assert len(re.findall(r'id="step-\d+"', html)) == len(steps)
        assert html.count("<rect x=") >= len(steps)  # one Gantt cell per step (+ tracks)
        for decision in traj["planner_decisions"]:
            assert f"<pre>{decision['raw_output']}</pre>" in html
        prompts = json.loads(gzip.decompress(
            (fixed_run / episode.key.folder() / "prompts.json.gz").read_bytes()))
        first = next(iter(prompts.values()))
        assert first.split("\n")[0] in html  # the stored prompt, not its hash only
        assert NO_PROMPT not in html
        assert episode.record["terminal_reason"] in html


def test_each_dimension_draws_its_own_signal(fixed_run: Path) -> None:
    pages = pages_of(fixed_run)
    by_dim = {e.record["dim"]: pages.episode(e) for e in pages.catalog.episodes()
              if e.key.condition == "D1_blind"}
    assert "M* = 7" in by_dim["D1"] and "Load balance" in by_dim["D1"]
    assert "Cabinet: " in by_dim["D2"] and "closed" in by_dim["D2"]
    assert "holder of Knife" in by_dim["D3"]
    assert "buffer occupancy" in by_dim["D4"] and "capacity 1" in by_dim["D4"]
    assert "Message board" in by_dim["D1"]  # the D1 (broadcast) condition has a board


def test_compare_page_aligns_the_conditions_of_one_instance(fixed_run: Path) -> None:
    html = pages_of(fixed_run).compare(TASKS[1])
    assert html is not None
    assert "greedy · C0_image" in html and "greedy · D1_blind" in html
    depth = max(r["num_steps"] for r in results(fixed_run) if r["task_id"] == TASKS[1])
    assert f'<td class="ordinal">{depth}</td>' in html
    assert f'<td class="ordinal">{depth + 1}</td>' not in html
    assert pages_of(fixed_run).compare("no-such-task") is None


def test_prompts_not_stored_degrades_to_a_note(run_copy: Path) -> None:
    for path in run_copy.glob("episodes/*/*/*/prompts.json.gz"):
        path.unlink()
    pages = pages_of(run_copy)
    html = pages.episode(pages.catalog.episodes()[0])
    assert NO_PROMPT in html and "prompts not stored in this run" in html


def test_newer_records_full_prompt_reply_arm_and_protocol_failure(run_copy: Path) -> None:
    """Fields other engineers may add (a decision's full prompt, an arm, error fields) show
    when present; a decision that landed nothing shows its protocol failure."""
    record = results(run_copy)[0]
    path = run_copy / record["trajectory"]
    traj = json.loads(path.read_text())
    first = traj["planner_decisions"][0]
    for item in traj["trajectory"]:
        if item.get("policy_decision") == first:
            item["policy_decision"]["prompt"] = "THE FULL PROMPT TEXT"
    first["prompt"] = "THE FULL PROMPT TEXT"
    traj["planner_decisions"].insert(1, {
        "agent": "agent_1", "status": "parse_error", "raw_output": "I think I will dance",
        "error": "no ACTION line", "prompt_hash": "feedbeef"})
    path.write_text(json.dumps(traj))
    lines = results(run_copy)
    lines[0] |= {"arm": "plan-then-act", "infra_error": None}
    (run_copy / "results.jsonl").write_text("".join(json.dumps(r) + "\n" for r in lines))
    pages = pages_of(run_copy)
    episode = next(e for e in pages.catalog.episodes() if e.record.get("arm"))
    html = pages.episode(episode)
    assert "THE FULL PROMPT TEXT" in html
    assert "I think I will dance" in html
    assert "protocol failure: parse_error" in html and "no ACTION line" in html
    assert "arm plan-then-act" in html
    assert "plan-then-act" in {r["v"][3] for r in listed(pages.runs())}


def test_junk_lines_are_skipped_and_counted(run_copy: Path) -> None:
    with open(run_copy / "results.jsonl", "a") as f:
        f.write("this is not json\n")
        f.write('{"model": "x"}\n')
    html = pages_of(run_copy).runs()
    assert "2 invalid result lines skipped." in html
    assert "line 9: not JSON" in html and "line 10: invalid result" in html
    assert len(listed(html)) == 8


def test_missing_trajectory_shows_the_result_line_only(run_copy: Path) -> None:
    record = results(run_copy)[0]
    (run_copy / record["trajectory"]).unlink()
    pages = pages_of(run_copy)
    episode = next(e for e in pages.catalog.episodes() if e.key.task_id == record["task_id"]
                   and e.key.condition == record["condition"])
    html = pages.episode(episode)
    assert "missing or unreadable" in html and record["terminal_reason"] in html
    assert pages.compare(record["task_id"]) is not None


def test_an_infrastructure_error_line_gets_its_episode_page(run_copy: Path) -> None:
    """A line of an episode that could not run (a runaway, a crash) carries no progress, steps
    or trajectory: its page says so and shows the error, in the served and exported viewer."""
    from benchmark_adapter.metrics import unrun_result
    from benchmark_adapter.tasks import load_tasks
    from cocobench_agents.runfolder.episode_key import EpisodeKey
    from cocobench_agents.runfolder.result_line import infra_error_line

    record = results(run_copy)[0]
    [config] = [c for c in load_tasks("cocobench-240") if c.task_id == record["task_id"]]
    key = EpisodeKey(record["model"], record["condition"], record["task_id"], epoch=3)
    line = infra_error_line(key, "memory: the episode grew its worker by more than 2048 MB",
                            unrun_result(config, planner=record["planner"]))
    with open(run_copy / "results.jsonl", "a") as f:
        f.write(json.dumps(line) + "\n")
    pages = pages_of(run_copy)
    episode = next(e for e in pages.catalog.episodes() if e.key.epoch == 3)
    html = html_text.unescape(pages.episode(episode))
    assert "grew its worker by more than 2048 MB" in html and "missing or unreadable" in html
    assert re.search(r"<dt>progress</dt><dd>—", html) and re.search(r"<dt>steps</dt><dd>—", html)
    assert main(["view", str(run_copy), "--export", str(run_copy.parent / "site")]) == 0
    assert list((run_copy.parent / "site").rglob("*@e3*.html"))


def test_live_reads_only_appended_lines_and_waits_for_a_torn_one(run_copy: Path) -> None:
    pages = pages_of(run_copy)
    catalog, run = pages.catalog, pages.catalog.runs[0]
    seq, size = catalog.seq, (run_copy / "results.jsonl").stat().st_size
    assert run._offset == size
    line = json.dumps(results(run_copy)[0] | {"epoch": 1})
    with open(run_copy / "results.jsonl", "a") as f:
        f.write(line[:40])  # a run in mid-write
    catalog.refresh()
    assert pages.new_rows(seq)["rows"] == [] and run._offset == size
    with open(run_copy / "results.jsonl", "a") as f:
        f.write(line[40:] + "\n")
    catalog.refresh()
    fresh = pages.new_rows(seq)
    assert len(fresh["rows"]) == 1 and fresh["rows"][0]["v"][4].endswith("@e1")
    assert fresh["episodes"] == 9 and fresh["seq"] == seq + 1
    # a retry of an episode replaces its row (same data-key), it is not a new episode
    retry = json.dumps(results(run_copy)[1] | {"terminal_reason": "retried"})
    with open(run_copy / "results.jsonl", "a") as f:
        f.write(retry + "\n")
    catalog.refresh()
    fresh = pages.new_rows(seq + 1)
    assert len(fresh["rows"]) == 1 and "retried" in fresh["rows"][0]["v"]
    assert fresh["episodes"] == 9


def test_two_runs_are_listed_together(fixed_run: Path, run_copy: Path) -> None:
    pages = pages_of(fixed_run, run_copy)
    html = pages.runs()
    assert len(listed(html)) == 16
    assert {e.path.split("/")[1] for e in pages.catalog.episodes()} == {"0", "1"}


def test_a_human_ai_team_is_named_by_its_seats_models(tmp_path: Path) -> None:
    """`--model greedy --agent-model agent_1=human` (the person played by code here): the
    runs table, the summary, the episode header, the team and every decision name the
    model of each seat."""
    out = tmp_path / "team"
    cb.run(cb.RunRequest(out=out, models=["greedy"], agent_models={"agent_1": "human"},
                         selection={"sources": ["demo"], "task_ids": [DEMO]},
                         conditions=["D1_blind"], max_steps=4), desk=OracleDesk([]))
    team = "agent_1: human · agent_2: greedy"
    pages = pages_of(out)
    runs = html_text.unescape(pages.runs())
    (row,) = listed(runs)
    assert row["v"][[key for key, _, _ in COLUMNS].index("model")] == team
    assert f"<td>{team}</td><td>D1_blind</td>" in runs  # the summary's row
    (episode,) = pages.catalog.episodes()
    page = html_text.unescape(pages.episode(episode))
    assert f'<p class="subtitle">{team} · D1_blind' in page
    assert "<li><strong>agent_1</strong>: human" in page
    seats = re.findall(r'<span class="seat"><strong>(\w+)</strong>: <span class="decided-by"'
                       r'[^>]*>(\w+)</span></span>', page)
    assert set(seats) == {("agent_1", "human"), ("agent_2", "greedy")}
    assert len(seats) == len(pages.catalog.runs[0].trajectory(episode)["planner_decisions"])


def test_the_error_column_counts_every_unanswered_call():
    from cocobench_agents.viewer.rows import error_label

    # The reference's backend_errors misses a call whose round ended the episode; the
    # usage counts it.
    assert error_label({"backend_errors": 0, "usage": {"backend_errors": 1}}) == "backend 1"
    assert error_label({"backend_errors": 2, "parse_errors": 1,
                        "usage": {"backend_errors": 2}}) == "backend 2, parse 1"
    assert error_label({"infra_error": "stalled"}) == "infra: stalled"
    assert error_label({"backend_errors": 0, "usage": None}) == "none"
