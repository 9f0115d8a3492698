"""Ablations in one run: repeated --prompt-suite and --planner are arms crossed with models
and conditions; every episode of each arm is recorded apart, resumed exactly, and a run of
one suite keeps the folders and result lines it had before arms existed."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from cocobench_agents.cli import main
from cocobench_agents.runfolder import EpisodeKey, RunFolder
from cocobench_agents.runfolder.episode_key import model_slug

BASE, NO_HINT = "cocobench-v1", "cocobench-v1+no-hint"
ARMS = ["--prompt-suite", BASE, "--prompt-suite", NO_HINT]
RUN = ["run", "--model", "random:3", "--suite", "demo"]


def run(out: Path, *extra: str) -> int:
    return main([*RUN, *extra, "--out", str(out)])


def lines(out: Path) -> list[dict]:
    return [json.loads(line) for line in (out / "results.jsonl").read_text().splitlines()]


def comparable(out: Path) -> dict[tuple, tuple[dict, str]]:
    """Result lines by episode (without wall-clock time), with their trajectory texts."""
    found = {}
    for record in lines(out):
        key = (record["model"], record["condition"], record.get("arm"), record["task_id"],
               record["epoch"])
        assert key not in found, f"{key} recorded twice"
        for where in ("elapsed_s", "node", "requeued"):  # wall-clock time; where Ray ran it
            record.pop(where, None)
        found[key] = (record, (out / record["trajectory"]).read_text())
    return found


@pytest.fixture(scope="module")
def two_suites(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("arms") / "two"
    assert run(out, *ARMS) == 0
    return out


def test_every_episode_runs_once_per_suite(two_suites):
    """Each arm plays every episode itself, under its own prompts. Its trajectory may equal
    the other arm's (random draws the same under both arms: common random numbers), so what
    tells the runs apart is the prompts each arm's episode sent and recorded."""
    records = lines(two_suites)
    assert len(records) == 8
    tasks = {r["task_id"] for r in records}
    assert len(tasks) == 4
    folder = RunFolder(two_suites)
    arm_folders = {BASE: BASE, NO_HINT: "cocobench-v1_no-hint"}
    for name in arm_folders.values():
        held = two_suites / "episodes" / "random_3" / "C0_image" / name
        assert {p.name for p in held.iterdir()} == tasks
    sent_other_prompts = set()
    for task in tasks:
        mine = [r for r in records if r["task_id"] == task]
        assert sorted(r["arm"] for r in mine) == [BASE, NO_HINT]
        assert [r["prompt_suite"] for r in sorted(mine, key=lambda r: r["arm"])] == [BASE,
                                                                                     NO_HINT]
        paths = {r["arm"]: r["trajectory"] for r in mine}
        assert paths == {arm: f"episodes/random_3/C0_image/{name}/{task}/trajectory.json"
                         for arm, name in arm_folders.items()}
        hashes = {}
        for arm, path in paths.items():
            decisions = json.loads((two_suites / path).read_text())["planner_decisions"]
            hashes[arm] = {d["prompt_hash"] for d in decisions}
            recorded = folder.prompts(EpisodeKey("random:3", "C0_image", task, 0, arm))
            assert hashes[arm] and hashes[arm] <= recorded.keys(), (task, arm)
        if hashes[BASE] != hashes[NO_HINT]:
            sent_other_prompts.add(task)
    # The instances whose prompts carry a coordination hint were sent other prompts by the
    # no-hint arm; the others' prompts are the same text under both suites.
    assert sent_other_prompts == {"K_D3__DemoKitchen1__seed0", "J_D4__DemoBedroom2__seed0"}


def test_each_arm_was_sent_its_own_prompts(two_suites):
    """The no-hint arm's prompts lack the coordination hint its baseline's prompts carry."""
    folder = RunFolder(two_suites)
    task = "K_D3__DemoKitchen1__seed0"  # a resource-constrained instance: it has a hint
    base = folder.prompts(EpisodeKey("random:3", "C0_image", task, 0, BASE))
    ablated = folder.prompts(EpisodeKey("random:3", "C0_image", task, 0, NO_HINT))
    assert base and ablated and not set(base) & set(ablated)
    assert any("RESOURCE" in text for text in base.values())
    assert not any("RESOURCE" in text for text in ablated.values())


def test_run_json_records_every_suite_and_the_arms(two_suites):
    record = json.loads((two_suites / "run.json").read_text())
    assert record["plan"]["arms"] == [BASE, NO_HINT]
    assert "prompt_suite" not in record
    suites = record["prompt_suites"]
    assert [(s["arm"], s["spec"]) for s in suites] == [(BASE, BASE), (NO_HINT, NO_HINT)]
    assert suites[0]["content_hash"] != suites[1]["content_hash"]
    assert record["request"]["prompt_suites"] == [BASE, NO_HINT]


def test_the_summary_has_an_arm_column_only_with_arms(two_suites, tmp_path, capsys):
    assert main(["run", "--out", str(two_suites), "--resume"]) == 0
    out, err = capsys.readouterr()
    assert "8 episodes (8 already done)" in err
    assert out.splitlines()[0].split()[:4] == ["model", "condition", "arm", "episodes"]
    assert f"random:3   C0_image    {NO_HINT}   4" in out
    assert run(tmp_path / "one", "--max-steps", "2") == 0
    out, _ = capsys.readouterr()
    assert out.splitlines()[0].split()[:3] == ["model", "condition", "episodes"]


def test_the_viewer_shows_each_arm_apart(two_suites):
    from cocobench_agents.viewer.pages import Pages
    from cocobench_agents.viewer.source import Catalog

    pages = Pages.create(Catalog([two_suites]), live=False)
    html = pages.runs()
    episodes = pages.catalog.episodes()
    assert len({e.path for e in episodes}) == 8
    assert "<th>arm</th>" in html and f"<td>{NO_HINT}</td>" in html  # the summary's column
    for episode in episodes:
        assert f"/C0_image/{model_slug(episode.key.arm)}/" in episode.path
        assert pages.catalog.runs[0].trajectory(episode) is not None


def test_resume_completes_exactly_the_missing_episodes(two_suites, tmp_path, capsys):
    out = tmp_path / "resumed"
    out.mkdir()
    (out / "run.json").write_text((two_suites / "run.json").read_text())
    kept = [line for line in (two_suites / "results.jsonl").read_text().splitlines(True)
            if json.loads(line)["task_id"] != "G_D1__DemoLivingRoom1__seed0"
            and not (json.loads(line)["arm"] == NO_HINT
                     and json.loads(line)["task_id"].startswith("K_"))]
    assert len(kept) == 5
    (out / "results.jsonl").write_text("".join(kept))
    for line in kept:
        record = json.loads(line)
        target = out / record["trajectory"]
        target.parent.mkdir(parents=True)
        target.write_text((two_suites / record["trajectory"]).read_text())
    assert main(["run", "--out", str(out), "--resume"]) == 0
    assert "8 episodes (5 already done)" in capsys.readouterr().err
    assert (out / "results.jsonl").read_text().startswith("".join(kept))  # kept as they were
    assert comparable(out) == comparable(two_suites)


def test_resume_refuses_other_suites_and_an_edited_suite_folder(tmp_path, capsys):
    suite = tmp_path / "mine"
    assert main(["prompts", "export", BASE, str(suite)]) == 0
    out = tmp_path / "run"
    assert run(out, "--prompt-suite", BASE, "--prompt-suite", str(suite), "--limit", "1",
               "--max-steps", "2") == 0
    record = json.loads((out / "run.json").read_text())
    assert record["plan"]["arms"] == [BASE, "mine"]
    assert record["prompt_suites"][1]["path"] == str(suite)
    capsys.readouterr()
    assert main(["run", "--out", str(out), "--resume", "--prompt-suite", BASE]) == 2
    assert "--prompt-suite" in capsys.readouterr().err
    with open(suite / "centralized.txt", "a", encoding="utf-8") as f:
        f.write("\nThink step by step.\n")
    assert main(["run", "--out", str(out), "--resume"]) == 2
    err = capsys.readouterr().err
    assert "changed since the run was recorded" in err and "centralized.txt" in err
    assert "Traceback" not in err


def test_two_suites_that_would_share_an_arm_are_refused(tmp_path, capsys):
    for parent in ("a", "b"):
        assert main(["prompts", "export", BASE, str(tmp_path / parent / "suite")]) == 0
    capsys.readouterr()
    code = run(tmp_path / "run", "--prompt-suite", str(tmp_path / "a" / "suite"),
               "--prompt-suite", str(tmp_path / "b" / "suite"))
    err = capsys.readouterr().err
    assert code == 2 and "would share the arm 'suite'" in err
    assert str(tmp_path / "a" / "suite") in err and str(tmp_path / "b" / "suite") in err
    assert not (tmp_path / "run").exists()
    assert run(tmp_path / "run2", "--prompt-suite", BASE, "--prompt-suite", "nope") == 2
    assert "unknown prompt suite 'nope'" in capsys.readouterr().err


def test_a_single_suite_run_is_laid_out_as_before(tmp_path):
    out = tmp_path / "one"
    assert run(out, "--prompt-suite", NO_HINT, "--max-steps", "2") == 0
    records = lines(out)
    assert all("arm" not in r for r in records)
    assert {r["trajectory"] for r in records} == {
        f"episodes/random_3/C0_image/{r['task_id']}/trajectory.json" for r in records}
    record = json.loads((out / "run.json").read_text())
    assert "prompt_suites" not in record and "arms" not in record["plan"]
    assert record["prompt_suite"]["spec"] == NO_HINT
    assert record["request"]["prompt_suites"] == [NO_HINT]
    assert record["request"]["planners"] == ["centralized"]


def test_a_run_folder_recorded_before_arms_resumes(tmp_path, capsys):
    """Its cli_options hold single values and its result lines carry no arm."""
    out = tmp_path / "old"
    assert run(out, "--max-steps", "2") == 0
    path = out / "results.jsonl"
    path.write_text("".join(path.read_text().splitlines(True)[:2]))
    capsys.readouterr()
    assert main(["run", "--out", str(out), "--resume", "--prompt-suite", BASE,
                 "--planner", "centralized", "--obs", "image"]) == 0
    assert "4 episodes (2 already done)" in capsys.readouterr().err
    assert len(lines(out)) == 4 and all("arm" not in r for r in lines(out))


def test_planner_arms_are_conditions(tmp_path):
    out = tmp_path / "planners"
    assert main(["run", "--model", "greedy", "--suite", "demo", "--max-steps", "4",
                 "--planner", "centralized", "--planner", "leader-worker",
                 "--planner", "C0",  # the same planner by its code: one arm
                 "--obs", "image", "--obs", "blind", "--out", str(out)]) == 0
    record = json.loads((out / "run.json").read_text())
    assert record["plan"]["conditions"] == ["C0_image", "C0_blind", "LW_image", "LW_blind"]
    assert record["plan"]["planner_arms"] == record["plan"]["conditions"]
    assert sorted({r["condition"] for r in lines(out)}) == ["C0_blind", "C0_image",
                                                           "LW_blind", "LW_image"]
    assert all("arm" not in r for r in lines(out))
    assert main(["report", str(out), "--out", str(out / "report"), "--no-plots"]) == 0
    table = (out / "report" / "arms.csv").read_text()
    assert "greedy,image,LW_image - C0_image,C0_image,4," in table
    assert "greedy,blind,LW_blind - C0_blind,C0_blind,4," in table


@pytest.mark.slow
@pytest.mark.parametrize("executor", [
    ("--workers", "2", "--jobs", "4"),
    pytest.param(("--executor", "ray", "--jobs", "2"), marks=pytest.mark.needs_ray),
], ids=["workers", "ray"])
def test_other_executors_record_what_one_process_records(two_suites, tmp_path, executor):
    out = tmp_path / "run"
    done = subprocess.run([sys.executable, "-m", "cocobench_agents.cli", *RUN, *ARMS,
                           *executor, "--out", str(out)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert comparable(out) == comparable(two_suites)
