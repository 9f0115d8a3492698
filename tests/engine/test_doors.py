"""One engine, many doors: the Python API and the command line end in the same request and
the same run folder; the engine needs no front end; a dry run spends nothing."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import cocobench_agents as cb
from cocobench_agents.cli import main
from tests.models.fake_openai import FakeOpenAI, ok

#: Prints the modules that imported click or rich while the engine ran: an import hook
#: records the first frame outside the import machinery.
WHO_IMPORTS_FRONT_ENDS = textwrap.dedent("""
    import importlib.abc, json, sys
    importers = set()

    class Watch(importlib.abc.MetaPathFinder):
        def find_spec(self, name, path=None, target=None):
            if name in ("click", "rich"):
                frame = sys._getframe(1)
                while frame and frame.f_globals.get("__name__", "").startswith(
                        ("importlib", "_frozen")):
                    frame = frame.f_back
                importers.add(frame.f_globals.get("__name__", "?") if frame else "?")
            return None

    sys.meta_path.insert(0, Watch())
    import cocobench_agents as cb
    request = cb.RunRequest(out=sys.argv[1], models=["greedy"],
                            selection={"sources": ["demo"], "limit": 1}, max_steps=2)
    light = sorted(m for m in ("click", "rich") if m in sys.modules)
    cb.plan(request)
    results = cb.run(request)
    print(json.dumps({"light": light, "importers": sorted(importers),
                      "episodes": len(results)}))
""")


@pytest.mark.slow
def test_the_engine_imports_no_front_end(tmp_path):
    done = subprocess.run([sys.executable, "-c", WHO_IMPORTS_FRONT_ENDS, str(tmp_path / "r")],
                          capture_output=True, text=True, timeout=300, check=True)
    report = json.loads(done.stdout.strip().splitlines()[-1])
    assert report["episodes"] == 1
    assert report["light"] == []  # the package and its request: nothing of either
    # LangGraph and LiteLLM bring httpx, whose optional command line imports both; none of
    # our modules does
    ours = [m for m in report["importers"]
            if m.startswith(("cocobench_agents", "benchmark_adapter"))]
    assert ours == []


def test_evaluate_and_the_command_record_the_same_request(tmp_path):
    argv = ["run", "--suite", "demo", "--model", "random:3", "--conditions",
            "C0_image,D0_blind", "--max-steps", "4", "--limit", "2", "--jobs", "2"]
    assert main([*argv, "--out", str(tmp_path / "cli")]) == 0
    cb.evaluate("demo", models="random:3", conditions="C0_image,D0_blind", max_steps=4,
                limit=2, jobs=2, out=tmp_path / "api")
    records = {name: json.loads((tmp_path / name / "run.json").read_text())
               for name in ("cli", "api")}
    requests = [{**r["request"], "out": None} for r in records.values()]
    assert requests[0] == requests[1]
    assert records["api"]["command"] == records["cli"]["command"].replace("/cli", "/api")
    assert "--model random:3" in records["api"]["command"]  # never the Python process's argv
    assert (tmp_path / "api" / "results.jsonl").read_text().count("\n") == 4


def test_the_recorded_command_runs_the_same_run(tmp_path):
    assert main(["run", "--suite", "demo", "--model", "greedy", "--agent-model",
                 "agent_2=random:1", "--conditions", "D1_blind", "--max-steps", "3",
                 "--extra", '{"top_p": 0.5}', "--out", str(tmp_path / "a")]) == 0
    command = json.loads((tmp_path / "a" / "run.json").read_text())["command"]
    words = __import__("shlex").split(command.replace(str(tmp_path / "a"),
                                                      str(tmp_path / "b")))
    assert words[:2] == ["cocobench", "run"]
    assert main(words[1:]) == 0
    requests = [json.loads((tmp_path / n / "run.json").read_text())["request"]
                for n in ("a", "b")]
    assert {**requests[0], "out": None} == {**requests[1], "out": None}


def test_evaluate_refuses_an_unknown_keyword_and_a_bad_value(tmp_path):
    with pytest.raises(TypeError, match="no option 'jbos'"):
        cb.evaluate("demo", models="greedy", out=tmp_path / "r", jbos=2)
    with pytest.raises(cb.EvaluationError, match="epochs"):
        cb.evaluate("demo", models="greedy", out=tmp_path / "r", epochs=0)
    assert not (tmp_path / "r").exists()


@pytest.mark.slow
def test_a_dry_run_calls_nothing_and_bounds_the_real_run(tmp_path, capsys):
    import litellm

    with FakeOpenAI(default=ok("REASON: go\nACTION: 2")) as server:
        argv = ["run", "--suite", "demo", "--only-cell", "G_D1", "--model",
                "openai/gpt-4o-mini", "--api-base", server.base_url, "--conditions",
                "C0_blind", "--max-steps", "3", "--out", str(tmp_path / "run")]
        assert main([*argv, "--dry-run", "--json"]) == 0
        estimate = json.loads(capsys.readouterr().out)
        assert server.count == 0 and not (tmp_path / "run").exists()
        assert main([*argv, "--no-preflight"]) == 0
        bodies = list(server.requests)
    [row] = estimate["rows"]
    assert row["episodes"] == 1 and 0 < len(bodies) <= row["max_calls"] == 3
    counted = litellm.token_counter(model="gpt-4o-mini", messages=bodies[0]["messages"])
    assert counted == row["prompt_tokens"]
    [episode] = estimate["episodes"]
    assert episode == {"model": "openai/gpt-4o-mini", "condition": "C0_blind", "arm": None,
                       "task_id": episode["task_id"], "epoch": 0, "prompt_tokens": counted}
    assert estimate["total"]["cost_usd"]["low"] <= estimate["total"]["cost_usd"]["high"]


@pytest.mark.slow
def test_a_dry_run_of_a_resumed_run_counts_what_is_left(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["run", "--suite", "demo", "--model", "greedy", "--max-steps", "2",
                 "--out", str(out)]) == 0
    lines = (out / "results.jsonl").read_text().splitlines(True)
    (out / "results.jsonl").write_text("".join(lines[:1]))
    capsys.readouterr()
    assert main(["run", "--out", str(out), "--resume", "--dry-run", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["total"]["episodes"] == 3
    assert (out / "results.jsonl").read_text().count("\n") == 1  # nothing ran


def test_a_mistake_in_a_dry_run_is_the_same_error_as_in_a_run(tmp_path, capsys):
    out = str(tmp_path / "run")
    assert main(["run", "--suite", "demo", "--model", "greedy", "--conditions", "C9_image",
                 "--out", out, "--dry-run"]) == 2
    assert "unknown condition 'C9_image'" in capsys.readouterr().err
    assert not Path(out).exists()
