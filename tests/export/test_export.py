"""`cocobench export` on real runs, loaded with Hugging Face `datasets` as it is: one row per
model decision, the messages equal to the run's kept prompts, the selectors, the image
column, the card, and no secret of the environment anywhere in what it writes."""

from __future__ import annotations

import base64
import io
import json
from collections import defaultdict
from pathlib import Path

import pytest
from PIL import Image

from cocobench_agents.export import COLUMNS
from tests.export.conftest import SOLVED
from tests.export.helpers import DATA, episode_of, export, load, model_decisions, result_lines
from tests.paths import SHARED_TASKS

pytestmark = pytest.mark.needs_export


def test_one_row_per_model_decision_with_the_messages_as_kept(capsys, played_run, tmp_path):
    code, out, err = export(capsys, played_run, "--out", tmp_path / "ds")
    assert code == 0, err
    assert out.split() == [str(tmp_path / "ds" / DATA), str(tmp_path / "ds" / "README.md")]
    rows = load(tmp_path / "ds", tmp_path / "cache")
    assert rows.column_names == [name for name, _, _ in COLUMNS]

    by_episode = defaultdict(list)
    for row in rows:
        by_episode[episode_of(row)].append(row)
    lines = result_lines(played_run)
    assert set(by_episode) == {episode_of(line) for line in lines}
    assert len(lines) == 20
    for line in lines:
        got = sorted(by_episode[episode_of(line)], key=lambda r: r["decision_index"])
        expected = model_decisions(played_run, line)
        assert len(got) == len(expected) > 0
        for index, (row, (decision, prompt)) in enumerate(zip(got, expected)):
            assert row["decision_index"] == index
            assert row["messages"] == [{"role": "user", "content": prompt}]
            assert row["reply"] == decision["raw_output"]
            assert (row["status"], row["parsed_action_id"], row["parsed_call"]) == (
                decision["status"], decision["parsed_action_id"], decision["parsed_call"])
            assert row["step"] == decision["step_index"]
            assert row["seat"] == (decision["agent"] or "team")
            assert row["seat_model"] == decision["model"] == line["model"]
            assert row["legal"] == {"action": True, "done": True, "parse_error": False,
                                    "invalid_action_id": False}[decision["status"]]
            assert row["episode_success"] == bool(line["task_success"])
            assert row["construct_score"] == line["construct_score"]
            assert row["episode_progress"] == line["task_progress"]
            assert row["image"] is None  # the harness keeps prompts, not frames
    seats = {(r["condition"][:2], r["seat"]) for r in rows}
    assert ("C0", "team") in seats and ("D1", "agent_2") in seats
    assert "C0" not in {c for c, s in seats if s != "team"}
    assert "(no messages yet)" in rows.filter(lambda r: r["condition"] == "D1_blind")[0][
        "messages"][0]["content"]


def test_the_card_names_the_runs_models_settings_and_columns(capsys, played_run, solved_run,
                                                             tmp_path):
    import datasets

    code, _, err = export(capsys, played_run, solved_run, "--out", tmp_path / "ds",
                          "--where", "condition=C0_blind")
    assert code == 0, err
    card = (tmp_path / "ds" / "README.md").read_text()
    for needed in ("## Run `played`", "## Run `scripted`", "greedy", "random:3",
                   "C0_image, C0_blind, D0_blind, D1_image, D1_blind",
                   "cocobench run --out", '"prompt_suite": "cocobench-v1"',
                   "episodes kept: condition=C0_blind", "states no licence",
                   "No row has an `image`", "| greedy | C0_blind | 2 | 0/2 |"):
        assert needed in card, needed
    assert all(f"| `{name}` |" in card for name, _, _ in COLUMNS)
    # The card's header makes the folder itself a dataset `datasets` loads.
    rows = datasets.load_dataset(str(tmp_path / "ds"), split="train",
                                 cache_dir=str(tmp_path / "cache"))
    assert set(rows["condition"]) == {"C0_blind"}
    assert set(rows["run"]) == {"played", "scripted"}


def test_where_selects_episodes(capsys, played_run, solved_run, tmp_path):
    def exported(*where: str) -> set[tuple[str, str, str]]:
        out = tmp_path / f"ds{len(list(tmp_path.iterdir()))}"
        code, _, err = export(capsys, played_run, solved_run, "--out", out,
                              *[a for w in where for a in ("--where", w)])
        assert code == 0, err
        return {episode_of(r) for r in load(out, tmp_path / "cache")}

    solved = {(f"scripted:{solved_run.parent / 'replies.json'}", "C0_blind", SOLVED)}
    assert exported("success") == solved
    played = {episode_of(line) for line in result_lines(played_run)}
    assert exported("failure") == played
    assert exported("model=random:3", "condition=D1_blind,D0_blind") == {
        e for e in played if e[0] == "random:3" and e[1] in ("D1_blind", "D0_blind")}
    assert exported("condition=C0_blind", "legal") == solved | {
        episode_of(line) for line in result_lines(played_run)
        if line["condition"] == "C0_blind" and line["legal_plan"]}


def test_frames_a_run_kept_become_an_image_column(capsys, run_copy, tmp_path):
    """Frames named the way the reference's recorder keeps them (an item's `image`: a file in
    the run folder, or a data URI) are the image of the decisions made in that state."""
    colours = {}
    for line in result_lines(run_copy):
        if line["condition"] != "D1_image" or line["model"] != "greedy":
            continue
        path = run_copy / line["trajectory"]
        document = json.loads(path.read_text())
        for item in document["trajectory"]:
            colour = (item["step_index"] * 20 % 256, 10, 200)
            png = _png(colour)
            if item["step_index"] % 2:  # odd steps as data URIs, even ones as files
                item["image"] = "data:image/png;base64," + base64.b64encode(png).decode()
            else:
                relative = f"{path.parent.relative_to(run_copy)}/step_{item['step_index']}.png"
                (run_copy / relative).write_bytes(png)
                item["image"] = relative
            colours[(line["task_id"], item["step_index"])] = colour
        document["trajectory"][0]["image"] = "../../../../outside.png"  # leaves the folder
        (tmp_path / "outside.png").write_bytes(_png((1, 2, 3)))
        path.write_text(json.dumps(document))

    code, _, err = export(capsys, run_copy, "--out", tmp_path / "ds")
    assert code == 0, err
    rows = load(tmp_path / "ds", tmp_path / "cache")
    framed = rows.filter(lambda r: r["condition"] == "D1_image" and r["model"] == "greedy")
    assert len(framed) > 0
    for row in framed:
        if row["step"] == 0:
            assert row["image"] is None  # its frame lies outside the run folder: not read
        else:
            assert isinstance(row["image"], Image.Image)
            assert row["image"].getpixel((0, 0)) == colours[(row["task_id"], row["step"])]
    assert all(r["image"] is None for r in rows.filter(lambda r: r["condition"] != "D1_image"
                                                        or r["model"] != "greedy"))
    card = (tmp_path / "ds" / "README.md").read_text()
    assert f"{sum(r['image'] is not None for r in framed)} of {len(rows)} rows have" in card


def _png(colour: tuple[int, int, int]) -> bytes:
    buffer = io.BytesIO()
    Image.new("RGB", (8, 6), colour).save(buffer, format="PNG")
    return buffer.getvalue()


SECRET = "sk-planted-5f0c1e2d3b4a69788796"
CREDENTIAL = "pl4nted-pass-word"


def test_no_secret_of_the_environment_reaches_the_export(capsys, monkeypatch, tmp_path):
    """A key in the environment, in the run's options and, as a model might echo it, in
    its recorded replies and prompts: none is in anything the export writes."""
    from tests.export.conftest import config

    monkeypatch.setenv("OPENAI_API_KEY", SECRET)
    run = tmp_path / "run"
    assert main_run(run, "--task", config(SOLVED), "--conditions", "D1_blind",
                    "--api-base", f"http://alice:{CREDENTIAL}@127.0.0.1:9/v1",
                    "--extra", json.dumps({"api_key": SECRET})) == 0
    _plant(run, SECRET)
    code, _, err = export(capsys, run, "--out", tmp_path / "ds")
    assert code == 0, err

    import pyarrow.parquet as pq

    written = json.dumps(pq.read_table(tmp_path / "ds" / DATA).to_pylist(), default=str)
    card = (tmp_path / "ds" / "README.md").read_text()
    assert "[REDACTED]" in written and "[REDACTED]" in card  # the planted ones, scrubbed
    for text in (written, card, err):
        assert SECRET not in text and CREDENTIAL not in text


def main_run(out: Path, *args: str) -> int:
    from cocobench_agents.cli import main

    return main(["run", "--model", "greedy", "--max-steps", "4", "--out", str(out), *args])


def _plant(run: Path, secret: str) -> None:
    """`secret` in every reply and prompt of the run (a model echoing a key it was told)."""
    import gzip

    for line in result_lines(run):
        path = run / line["trajectory"]
        document = json.loads(path.read_text())
        for decision in document["planner_decisions"]:
            if "raw_output" in decision:
                decision["raw_output"] += f"\nMSG: my key is {secret}"
        path.write_text(json.dumps(document))
        prompts_path = path.parent / "prompts.json.gz"
        prompts = json.loads(gzip.decompress(prompts_path.read_bytes()))
        prompts = {h: f"{p}\n(key: {secret})" for h, p in prompts.items()}
        prompts_path.write_bytes(gzip.compress(json.dumps(prompts).encode()))
    record = json.loads((run / "run.json").read_text())
    record["name"] = f"run-{secret}"
    (run / "run.json").write_text(json.dumps(record))


def test_an_export_is_a_copy_of_what_it_read(capsys, played_run, tmp_path):
    """Exporting changes nothing in the run folder (it may be read-only, or shared)."""
    before = {p: p.read_bytes() for p in played_run.rglob("*") if p.is_file()}
    code, _, err = export(capsys, played_run, "--out", tmp_path / "ds")
    assert code == 0, err
    assert {p: p.read_bytes() for p in played_run.rglob("*") if p.is_file()} == before


def test_a_leader_and_its_workers_are_rows_of_their_own(capsys, tmp_path):
    """Leader–worker: the leader's plan is a row for the team (its legality does not apply),
    each worker's choice a row of its seat; two prompt-suite arms are told apart."""
    from tests.export.conftest import config

    run = tmp_path / "run"
    assert main_run(run, "--task", config("K_D3__FloorPlan10__3agent_seed0"), "--planner",
                    "leader-worker", "--obs", "blind", "--prompt-suite", "cocobench-v1",
                    "--prompt-suite", "cocobench-v1+no-hint") == 0
    code, _, err = export(capsys, run, "--out", tmp_path / "ds")
    assert code == 0, err
    rows = load(tmp_path / "ds", tmp_path / "cache")
    assert set(rows["arm"]) == {"cocobench-v1", "cocobench-v1+no-hint"}
    leaders = rows.filter(lambda r: r["seat"] == "team")
    assert len(leaders) > 0 and set(leaders["status"]) == {"plan"}
    assert set(leaders["legal"]) == {None}
    workers = rows.filter(lambda r: r["seat"] != "team")
    assert set(workers["seat"]) == {"agent_1", "agent_2", "agent_3"}
    assert set(workers["legal"]) == {True}
    for line in result_lines(run):
        expected = [prompt for _, prompt in model_decisions(run, line)]
        got = rows.filter(lambda r, arm=line["arm"]: r["arm"] == arm)
        assert [m[0]["content"] for m in got["messages"]] == expected


def test_the_card_names_no_local_folder(capsys, played_run, tmp_path):
    """The runs were made with absolute paths (--task, --out): the card shows their last
    part only, not where they sat on this machine."""
    code, _, err = export(capsys, played_run, "--out", tmp_path / "ds")
    assert code == 0, err
    card = (tmp_path / "ds" / "README.md").read_text()
    assert "cocobench run --out played" in card and "A_D1__FloorPlan1__seed0.json" in card
    for folder in (played_run.parent, SHARED_TASKS, Path.home()):
        assert str(folder) not in card


def test_a_decisions_reward_is_what_the_environment_pays(capsys, solved_run, played_run,
                                                         tmp_path):
    """The ``reward`` column: the solved episode's rewards are the progress each call made
    (summing to the goal's), success and half its construct score on its last decision; a
    failed call or an off-menu reply of the played runs costs 0.002."""
    from cocobench_agents.rewards import DEFAULT_WEIGHTS

    code, _, err = export(capsys, solved_run, played_run, "--out", tmp_path / "ds")
    assert code == 0, err
    rows = load(tmp_path / "ds", tmp_path / "cache")
    solved = sorted((r for r in rows if r["run"] == "scripted"),
                    key=lambda r: r["decision_index"])
    [line] = result_lines(solved_run)
    items = json.loads((solved_run / line["trajectory"]).read_text())["trajectory"]
    checks = [i["eval"]["checks"] for i in items if i.get("eval")]
    start = sum(c["passed"] for c in checks[0]) / len(checks[0])
    end = 1.0 + 0.5 * line["construct_score"]
    assert line["task_success"] and all(r["step_success"] is not False for r in solved)
    assert sum(r["reward"] for r in solved) == pytest.approx(1.0 - start + end)
    assert solved[-1]["reward"] >= end
    costly = rows.filter(lambda r: r["run"] == "played" and not r["episode_success"] and (
        r["step_success"] is False or r["legal"] is False))
    assert len(costly) > 0
    assert set(costly["reward"]) == {-DEFAULT_WEIGHTS["legality"]}
