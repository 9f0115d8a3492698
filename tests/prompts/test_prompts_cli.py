"""`cocobench prompts` (list, export, show) and `cocobench run --prompt-suite PATH`: the edit a
researcher makes is what the model gets, the run records the suite's hash, a resume refuses a
changed suite, and every mistake is one line with exit code 2."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from cocobench_agents.cli import main
from cocobench_agents.prompts import DEFAULT_SUITE, TEMPLATE_FIELDS, load_prompt_suite
from cocobench_agents.tools import prompt_hash

J_D4, K_D3 = "J_D4__DemoBedroom2__seed0", "K_D3__DemoKitchen1__seed0"
EDIT = ("Choose the single best NEXT action", "EDITED: choose the single best NEXT action")


def cocobench(capsys, *argv: str) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    return code, out, err


def edited_suite(capsys, folder: Path) -> Path:
    """Export the shipped suite and edit the centralized template: drop the hint line and
    reword one sentence."""
    code, out, _ = cocobench(capsys, "prompts", "export", DEFAULT_SUITE, folder)
    assert code == 0 and f"wrote {len(TEMPLATE_FIELDS) + 1} files" in out
    template = folder / "centralized.txt"
    text = template.read_text()
    assert "{hint}\n" in text and EDIT[0] in text
    template.write_text(text.replace("{hint}\n", "").replace(*EDIT))
    return folder


def show(capsys, *argv: str) -> str:
    code, out, err = cocobench(capsys, "prompts", "show", "--source", "demo", "--obs", "blind",
                               *argv)
    assert code == 0, err
    assert err.startswith("# step 0 prompt")
    return out.removesuffix("\n")


# -- list, export ----------------------------------------------------------------------------

def test_list_names_the_shipped_suites_and_the_variants(capsys) -> None:
    code, out, _ = cocobench(capsys, "prompts", "list")
    assert code == 0
    assert DEFAULT_SUITE in out and load_prompt_suite().content_hash[:12] in out
    assert all(v in out for v in ("no-hint", "no-progress", "no-history"))


def test_export_writes_a_loadable_copy(capsys, tmp_path: Path) -> None:
    code, out, _ = cocobench(capsys, "prompts", "export", DEFAULT_SUITE, tmp_path / "a" / "b")
    assert code == 0 and "--prompt-suite" in out
    copy = load_prompt_suite(str(tmp_path / "a" / "b"))
    assert copy.content_hash == load_prompt_suite().content_hash


@pytest.mark.parametrize("kind", ["non-empty folder", "file"])
def test_export_refuses_to_overwrite(capsys, tmp_path: Path, kind: str) -> None:
    target = tmp_path / "target"
    if kind == "file":
        target.write_text("keep me")
    else:
        target.mkdir()
        (target / "centralized.txt").write_text("keep me")
    code, out, err = cocobench(capsys, "prompts", "export", DEFAULT_SUITE, target)
    assert code == 2 and out == ""
    assert err == (f"cocobench: error: {target}: exists and is not an empty folder; export "
                   f"into a new or empty one\n")
    kept = target if kind == "file" else target / "centralized.txt"
    assert kept.read_text() == "keep me"


def test_export_into_an_unwritable_place(capsys, tmp_path: Path) -> None:
    (tmp_path / "a-file").write_text("")
    code, _, err = cocobench(capsys, "prompts", "export", DEFAULT_SUITE, tmp_path / "a-file" / "x")
    assert code == 2 and err.startswith(f"cocobench: error: {tmp_path}/a-file/x: cannot write: ")


def test_export_takes_a_shipped_name_only(capsys, tmp_path: Path) -> None:
    for name in ("cocobench-v9", f"{DEFAULT_SUITE}+no-hint"):
        code, _, err = cocobench(capsys, "prompts", "export", name, tmp_path / "x")
        assert code == 2 and f"unknown prompt suite {name!r}" in err
    assert not (tmp_path / "x").exists()


# -- show ------------------------------------------------------------------------------------

def test_show_prints_the_edited_prompt_and_variants_apply(capsys, tmp_path: Path) -> None:
    suite = edited_suite(capsys, tmp_path / "suite")
    shipped, edited = show(capsys, "--task", J_D4), show(capsys, "--suite", suite, "--task", J_D4)
    assert "RELAY CONSTRAINT" in shipped and EDIT[0] in shipped
    assert "RELAY CONSTRAINT" not in edited and EDIT[1] in edited
    assert set(shipped.splitlines()) - set(edited.splitlines()) == {
        next(line for line in shipped.splitlines() if "RELAY CONSTRAINT" in line),
        next(line for line in shipped.splitlines() if EDIT[0] in line)}
    no_progress = show(capsys, "--suite", f"{suite}+no-progress", "--task", J_D4)
    assert "GOAL PROGRESS" in edited and "GOAL PROGRESS" not in no_progress


def test_show_a_decentralized_agent_and_the_leader(capsys) -> None:
    second = show(capsys, "--task", J_D4, "--planner", "decentralized-broadcast",
                  "--agent", "agent_2")
    assert second.startswith("You are agent_2,") and "TEAMMATE MESSAGES" in second
    first = show(capsys, "--task", J_D4, "--planner", "decentralized")
    assert first.startswith("You are agent_1,") and "TEAMMATE MESSAGES" not in first
    assert show(capsys, "--task", J_D4, "--planner", "leader-worker").startswith(
        "You are the team leader")


def test_show_takes_a_config_file(capsys, tmp_path: Path) -> None:
    from benchmark_adapter.tasks import load_tasks

    config = next(c for c in load_tasks("demo") if c.task_id == K_D3)
    assert show(capsys, "--task", config.source) == show(capsys, "--task", K_D3)


@pytest.mark.parametrize(("argv", "message"), [
    (["--task", "X_D9__nowhere"],
     "Invalid value for --task: unknown task 'X_D9__nowhere': no instance 'X_D9__nowhere' in demo"),
    (["--task", J_D4, "--planner", "oracle"], "'oracle' has no prompt to show"),
    (["--task", J_D4, "--planner", "nope"], "unknown planner 'nope'"),
    (["--task", J_D4, "--agent", "agent_1"], "the centralized planner's first prompt is the "
                                             "team's, not an agent's"),
    (["--task", J_D4, "--planner", "leader-worker", "--agent", "agent_1"], "the leader's"),
    (["--task", J_D4, "--planner", "decentralized", "--agent", "agent_7"],
     "'agent_7' is not an agent of J_D4__DemoBedroom2__seed0 (agent_1, agent_2)"),
    (["--task", J_D4, "--suite", "cocobench-v1+no-hints"], "unknown prompt variant 'no-hints'"),
])
def test_show_mistakes(capsys, argv: list[str], message: str) -> None:
    code, out, err = cocobench(capsys, "prompts", "show", "--source", "demo", *argv)
    assert code == 2 and out == "" and message in err
    assert err.strip().splitlines()[-1].startswith(("Error: ", "cocobench: error: "))


def test_show_a_file_of_several_tasks_needs_an_id(capsys, tmp_path: Path) -> None:
    from benchmark_adapter.tasks import load_tasks

    index = tmp_path / "index.json"
    index.write_text(json.dumps({"instances": [{"config": c.source}
                                               for c in load_tasks("demo")[:2]]}))
    code, _, err = cocobench(capsys, "prompts", "show", "--task", index)
    assert code == 2 and f"{index} holds 2 instances; pass --source {index} --task ID" in err
    code, _, err = cocobench(capsys, "prompts", "show", "--task", index.parent)
    assert code == 2 and f"no instance '{index.parent}' in cocobench-240" in err


def test_show_a_broken_suite_names_the_file_and_field(capsys, tmp_path: Path) -> None:
    suite = edited_suite(capsys, tmp_path / "suite")
    (suite / "hint_relay.txt").write_text("Only {producer} may use {bufer}.")
    code, out, err = cocobench(capsys, "prompts", "show", "--suite", suite, "--task", J_D4,
                               "--source", "demo")
    assert code == 2 and out == ""
    assert err.startswith(f"cocobench: error: {suite.resolve()}/hint_relay.txt: unknown field "
                          f"{{bufer}} (fields of this template: buffer, consumer, producer, "
                          f"targets)")


def test_show_imports_no_model_stack(tmp_path: Path) -> None:
    script = ("import sys; from cocobench_agents.cli import main; "
              f"code = main(['prompts', 'show', '--task', '{J_D4}', '--source', 'demo']); "
              "print(code, sorted(m for m in ('litellm', 'langgraph') if m in sys.modules))")
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          timeout=120, cwd=tmp_path)
    assert done.stdout.splitlines()[-1] == "0 []", done.stderr


# -- run --prompt-suite PATH -----------------------------------------------------------------

RUN = ["run", "--model", "greedy", "--suite", "demo", "--task-id", J_D4, "--task-id", K_D3,
       "--limit", "2", "--obs", "blind", "--jobs", "2"]


@pytest.mark.slow
def test_the_model_gets_the_edited_prompt_and_run_json_records_the_hash(
        capsys, tmp_path: Path) -> None:
    suite, out = edited_suite(capsys, tmp_path / "suite"), tmp_path / "run"
    code, _, err = cocobench(capsys, *RUN, "--prompt-suite", suite, "--out", out)
    assert code == 0, err
    record = json.loads((out / "run.json").read_text())["prompt_suite"]
    loaded = load_prompt_suite(str(suite))
    assert record["content_hash"] == loaded.content_hash != load_prompt_suite().content_hash
    assert record["path"] == record["spec"] == str(suite.resolve())
    results = [json.loads(line) for line in (out / "results.jsonl").read_text().splitlines()]
    assert sorted(r["task_id"] for r in results) == [J_D4, K_D3]
    for result in results:
        assert result["prompt_suite"] == str(suite.resolve())
        first = json.loads((out / result["trajectory"]).read_text())["planner_decisions"][0]
        shown = show(capsys, "--suite", suite, "--task", result["task_id"])
        assert EDIT[1] in shown and "CONSTRAINT" not in shown
        assert first["prompt_hash"] == prompt_hash(shown)


@pytest.mark.slow
def test_resume_refuses_a_changed_or_missing_suite(capsys, tmp_path: Path) -> None:
    suite, out = edited_suite(capsys, tmp_path / "suite"), tmp_path / "run"
    assert cocobench(capsys, *RUN, "--prompt-suite", f"{suite}+no-history", "--out", out)[0] == 0
    recorded = (out / "results.jsonl").read_text()
    leader = suite / "leader.txt"
    original = leader.read_text()
    leader.write_text(original + "\nBe brief.")
    code, out_text, err = cocobench(capsys, "run", "--out", out, "--resume")
    assert code == 2 and out_text == ""
    assert err == (f"cocobench: error: --resume: prompt suite {suite.resolve()}+no-history "
                   f"changed since the run was recorded (changed: leader.txt); restore it, "
                   f"or start a new run in another --out\n")
    code, _, err = cocobench(capsys, *RUN, "--prompt-suite", suite, "--out", out, "--resume")
    assert code == 2 and "differs from the recorded run" in err and "prompt" in err
    leader.write_text(original)  # restored: the resume goes on (nothing left to run)
    code, _, err = cocobench(capsys, "run", "--out", out, "--resume")
    assert code == 0 and "2 episodes (2 already done)" in err
    for path in suite.iterdir():
        path.unlink()
    suite.rmdir()
    code, _, err = cocobench(capsys, "run", "--out", out, "--resume")
    assert code == 2 and err == (f"cocobench: error: prompt suite folder {suite.resolve()}: "
                                 f"no such folder\n")
    assert (out / "results.jsonl").read_text() == recorded  # nothing recorded is lost


@pytest.mark.slow
def test_a_relative_suite_path_resumes_from_another_directory(
        capsys, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    edited_suite(capsys, Path("suite"))
    assert cocobench(capsys, *RUN, "--prompt-suite", "suite+no-hint", "--out", "run")[0] == 0
    spec = f"{tmp_path / 'suite'}+no-hint"
    record = json.loads(Path("run/run.json").read_text())
    assert record["prompt_suite"]["spec"] == spec and record["request"]["prompt_suites"] == [spec]
    (tmp_path / "elsewhere").mkdir()
    monkeypatch.chdir(tmp_path / "elsewhere")
    code, _, err = cocobench(capsys, "run", "--out", tmp_path / "run", "--resume")
    assert code == 0 and "2 episodes (2 already done)" in err


@pytest.mark.parametrize(("breakage", "message"), [
    ("suite.json", "suite.json: missing"),
    ("distributed.txt", "distributed.txt: template missing"),
])
def test_run_with_a_broken_suite_fails_before_creating_the_run(
        capsys, tmp_path: Path, breakage: str, message: str) -> None:
    suite = edited_suite(capsys, tmp_path / "suite")
    (suite / breakage).unlink()
    code, _, err = cocobench(capsys, *RUN, "--prompt-suite", suite, "--out", tmp_path / "run")
    assert code == 2 and err == f"cocobench: error: {suite.resolve()}/{message}" + (
        f" (a prompt suite folder holds suite.json and its templates; start from `cocobench "
        f"prompts export {DEFAULT_SUITE} DIR`)\n" if breakage == "suite.json" else "\n")
    assert not (tmp_path / "run").exists()
