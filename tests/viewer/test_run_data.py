"""A run folder is data, shared by whoever made it (issue 34): the viewer, live and
`--export`, never runs code the folder names, writes nothing outside its export folder
whatever names the folder holds, and answers a malformed field with a page and a warning."""

from __future__ import annotations

import gzip
import json
import re
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from cocobench_agents.cli import main
from cocobench_agents.viewer.pages import Pages
from cocobench_agents.viewer.server import ViewerServer
from cocobench_agents.viewer.source import Catalog
from tests.readers.mutations import Deep, dumps

from .hostile import send
from .test_pages import listed, results

#: What a planted canary writes when it runs: the test fails if the file exists.
CANARY = """
from pathlib import Path
Path({mark!r}).write_text("the viewer ran this file")
def build_x(): raise SystemExit("never")
"""


def append(run: Path, *lines: dict[str, Any]) -> None:
    with open(run / "results.jsonl", "a") as f:
        for line in lines:
            f.write(json.dumps(line) + "\n")


def every_page(pages: Pages) -> list[str]:
    """Every page the viewer has for its runs (as the live server renders them)."""
    episodes = pages.catalog.episodes()
    return [pages.runs(), *(pages.episode(e) for e in episodes),
            *(pages.compare(e.key.task_id) or "" for e in episodes)]


@pytest.fixture
def canaries(run_copy: Path, tmp_path: Path,
             monkeypatch: pytest.MonkeyPatch) -> Iterator[list[Path]]:
    """`code/payload.py` planted in the run folder and `canary_mod.py` in a folder on
    `sys.path`; each writes its mark file when it runs. Yields the mark files."""
    marks = [tmp_path / "PWNED-file.txt", tmp_path / "PWNED-module.txt"]
    (run_copy / "code").mkdir()
    (run_copy / "code" / "payload.py").write_text(CANARY.format(mark=str(marks[0])))
    site = tmp_path / "site-packages"
    site.mkdir()
    (site / "canary_mod.py").write_text(CANARY.format(mark=str(marks[1])))
    monkeypatch.syspath_prepend(str(site))
    monkeypatch.delitem(sys.modules, "canary_mod", raising=False)
    yield marks
    assert "canary_mod" not in sys.modules


def test_a_code_reference_in_a_condition_never_runs(run_copy: Path, canaries: list[Path],
                                                    tmp_path: Path) -> None:
    """The issue's reproduction: a line whose condition names a planner file of the run
    folder (or a module) is shown like any other, live and exported, and the code never
    runs."""
    line = results(run_copy)[0]
    payload = run_copy / "code" / "payload.py"
    append(run_copy, line | {"condition": f"{payload}:build_x_blind"},
           line | {"condition": "code/payload.py:build_x_blind", "planner": f"{payload}:x"},
           line | {"condition": "canary_mod:build_x_blind", "planner": "canary_mod:build_x"})
    pages = Pages.create(Catalog([run_copy]), live=True)
    assert all(every_page(pages))
    assert main(["view", str(run_copy), "--export", str(tmp_path / "site")]) == 0
    assert [mark for mark in canaries if mark.exists()] == []
    # Found by what a page shows, not its file name: a long condition's slug is cut, so
    # whether "payload" survives in the name depends on how long the temporary path is.
    shown = [p for p in (tmp_path / "site").rglob("*.html")
             if "payload.py:build_x_blind" in p.read_text() and "step-1" in p.read_text()]
    assert len([p for p in shown if "compare" not in p.parts]) == 2, shown


def board_shown(pages: Pages, condition: str) -> bool:
    episode = next(e for e in pages.catalog.episodes() if e.key.condition == condition)
    return "<h2>Message board</h2>" in pages.episode(episode)


def test_whether_a_planner_broadcasts_comes_from_the_run_s_record(run_copy: Path) -> None:
    """A built-in planner is known by its code; a planner from the run author's file by what
    `run.json` recorded of it; one the record does not describe shows the board only when a
    message was posted (greedy posts none)."""
    line = next(r for r in results(run_copy) if r["condition"] == "D1_blind")
    mine = "/elsewhere/mine.py:build_claims"
    append(run_copy, line | {"condition": "claims_blind", "planner": mine},
           line | {"condition": "quiet_blind", "planner": "/elsewhere/quiet.py:build_quiet"})
    record = json.loads((run_copy / "run.json").read_text())
    record["planners"] = {mine: {"code": "claims", "kind": "file", "broadcast": True,
                                 "prompt": "agent"}}
    (run_copy / "run.json").write_text(json.dumps(record))
    pages = Pages.create(Catalog([run_copy]), live=False)
    assert board_shown(pages, "D1_blind") and not board_shown(pages, "C0_image")
    assert board_shown(pages, "claims_blind") and not board_shown(pages, "quiet_blind")


def test_run_json_records_what_a_reader_needs_of_a_user_planner() -> None:
    from cocobench_agents.graphs.plugins import planners_record

    example = Path(__file__).resolve().parents[2] / "examples" / "strategies" / "first_come.py"
    [(_, record)] = planners_record([f"{example}:FIRST_COME"]).items()
    assert record["broadcast"] is True and record["prompt"] == "agent"


def files_under(folder: Path) -> set[Path]:
    return {p for p in folder.rglob("*") if p.is_file() or p.is_symlink()}


def test_no_key_of_a_run_folder_writes_outside_the_export(run_copy: Path,
                                                         tmp_path: Path) -> None:
    """`../` in a task id, condition, model or arm, and a frame named through `..`: every
    page and file lands inside the export folder (here eight folders deep in the test's
    folder, which is checked for anything else written)."""
    line = results(run_copy)[0]
    append(run_copy, line | {"task_id": "../../../../../ESCAPED"},
           line | {"condition": "../../../../../../ESCAPED_blind", "task_id": "t2"},
           line | {"model": "..", "arm": "..", "condition": "..", "task_id": "../../../E3"},
           line | {"task_id": "/tmp/ABSOLUTE", "epoch": 999_999},
           line | {"task_id": "x" * 3000})
    trajectory = run_copy / line["trajectory"]
    document = json.loads(trajectory.read_text())
    (run_copy / "frame.png").write_bytes(b"\x89PNG the frame")
    depth = len(trajectory.relative_to(run_copy).parts) - 1
    document["trajectory"][1]["image"] = "../" * depth + f"../{run_copy.name}/frame.png"
    document["trajectory"][2]["image"] = f"../../../../../../../..{run_copy}/frame.png"
    trajectory.write_text(json.dumps(document))
    before = files_under(tmp_path)
    site = tmp_path / "a" / "b" / "c" / "d" / "e" / "f" / "g" / "site"
    assert main(["view", str(run_copy), "--export", str(site)]) == 0
    new = files_under(tmp_path) - before
    assert new and all(p.is_relative_to(site) for p in new), sorted(new - files_under(site))
    assert not list(Path("/").glob("ESCAPED*")) and not list(tmp_path.rglob("ESCAPED.html"))
    copied = [p for p in (site / "files").rglob("*") if p.is_file()]
    assert [p.relative_to(site).as_posix() for p in copied] == ["files/0/frame.png"]
    for page in site.rglob("*.html"):  # every link resolves inside the export
        for ref in re.findall(r'(?:href|src)="([^"#?]+)', page.read_text()):
            if not ref.startswith("data:"):
                assert (page.parent / ref).resolve().is_relative_to(site), (page, ref)
    rows = listed((site / "index.html").read_text())
    assert len(rows) == 8 + 5 and all((site / r["h"]).is_file() for r in rows)


def test_the_live_viewer_serves_odd_keys_at_their_own_pages(run_copy: Path) -> None:
    line = results(run_copy)[0]
    append(run_copy, line | {"task_id": "../../../../../ESCAPED"},
           line | {"task_id": "a/b?c#d%2e"})
    with ViewerServer(Pages.create(Catalog([run_copy]), live=True), 0) as server:
        index = send(server.port, "/")
        rows = listed(index.raw.partition(b"\r\n\r\n")[2].decode())
        odd = [r for r in rows if "~" in r["h"]]
        assert len(odd) == 2
        for row in odd:
            assert send(server.port, "/" + row["h"]).status == 200
            assert send(server.port, "/" + row["c"]).status == 200


def _string_task_config(doc: dict[str, Any]) -> None:
    doc["task_config"] = "a task config that is a string"


def _agents_without_text_ids(doc: dict[str, Any]) -> None:
    doc["task_config"]["agents"] = [{"id": {"x": 1}}, {"id": [1]}, {"id": None}, 7, "agent"]


def _step_agents_not_text(doc: dict[str, Any]) -> None:
    for n, item in enumerate(doc["trajectory"]):
        if isinstance(item.get("skill_result"), dict):
            item["skill_result"]["agent"] = [{"x": 1}, 5, None, ["a"]][n % 4]


def _items_not_objects(doc: dict[str, Any]) -> None:
    doc["trajectory"] = [1, "two", None, [3], *doc["trajectory"]]


def _deep_trajectory(doc: dict[str, Any]) -> None:
    doc["trajectory"][0]["state"] = Deep(100_000)


def _evidence_of_wrong_type(line: dict[str, Any]) -> None:
    line["cross_construct"][line["dim"]]["evidence"] = ["not", "an", "object"]


def _decisions_not_objects(doc: dict[str, Any]) -> None:
    doc["planner_decisions"] = ["x", 1, {"prompt_hash": ["h"], "raw_output": {"a": 1}}]


def _final_eval_odd(doc: dict[str, Any]) -> None:
    doc["final_eval"] = {"checks": "all", "success": [1]}
    doc["task_config"]["provenance"] = "nowhere"


TRAJECTORY_MUTATIONS: dict[str, Callable[[dict[str, Any]], None]] = {
    "task_config a string": _string_task_config,
    "agents with non-string ids": _agents_without_text_ids,
    "steps whose agent is not text": _step_agents_not_text,
    "trajectory items not objects": _items_not_objects,
    "trajectory.json nested 100,000 deep": _deep_trajectory,
    "planner_decisions not objects": _decisions_not_objects,
    "final_eval and provenance odd": _final_eval_odd,
}


def check_served_and_exported(run: Path, export_to: Path) -> list[str]:
    """Every page of `run` served over HTTP (each answer < 500) and `--export` (exit 0):
    the pages' text."""
    bodies = []
    with ViewerServer(Pages.create(Catalog([run]), live=True), 0) as server:
        index = send(server.port, "/")
        assert index.status == 200
        assert send(server.port, "/api/rows").status == 200
        for row in listed(index.raw.partition(b"\r\n\r\n")[2].decode()):
            for target in (row["h"], row["c"]):
                answer = send(server.port, "/" + target)
                assert answer.status == 200, (target, answer.raw[-300:])
                bodies.append(answer.raw.decode("utf-8"))
    assert main(["view", str(run), "--export", str(export_to)]) == 0
    return bodies


@pytest.mark.parametrize("mutation", TRAJECTORY_MUTATIONS)
def test_a_malformed_trajectory_gives_a_page_with_a_warning(
        run_copy: Path, tmp_path: Path, mutation: str,
        capsys: pytest.CaptureFixture) -> None:
    for line in results(run_copy):
        path = run_copy / line["trajectory"]
        document = json.loads(path.read_text())
        TRAJECTORY_MUTATIONS[mutation](document)
        path.write_bytes(dumps(document))
    bodies = check_served_and_exported(run_copy, tmp_path / "site")
    err = capsys.readouterr().err
    assert "Traceback" not in err
    if any("cannot be shown" in b for b in bodies):  # --export says how many, in one line
        assert re.search(r"^cocobench view: \d+ episode\(s\) exported with their result "
                         r"line only, .* \(first: .*trajectory\.json: \w+", err, re.M), err
    assert any("cannot be shown" in b or "missing or unreadable" in b or 'id="step-1"' in b
               for b in bodies)


def test_deeply_nested_prompts_and_wrong_evidence_give_pages(run_copy: Path,
                                                            tmp_path: Path) -> None:
    lines = results(run_copy)
    for line in lines:
        prompts = Path(run_copy / line["trajectory"]).parent / "prompts.json.gz"
        prompts.write_bytes(gzip.compress(b"[" * 200_000 + b"]" * 200_000))
        _evidence_of_wrong_type(line)
    (run_copy / "results.jsonl").write_text("".join(json.dumps(r) + "\n" for r in lines))
    bodies = check_served_and_exported(run_copy, tmp_path / "site")
    assert any("malformed (a list, not an object)" in b for b in bodies)


def test_a_seat_model_that_is_not_text_breaks_no_page(run_copy: Path, tmp_path: Path) -> None:
    """One line with `"models": {"agent_1": {"x": 1}, "agent_2": "greedy"}` made `/` and
    `/api/rows` answer 500 for every run shown."""
    append(run_copy, results(run_copy)[0] | {"models": {"agent_1": {"x": 1},
                                                        "agent_2": "greedy"}, "epoch": 1})
    check_served_and_exported(run_copy, tmp_path / "site")


def test_a_results_file_that_cannot_be_read_is_one_line_or_kept(
        run_copy: Path, tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    """`results.jsonl` a folder: `view` stops in one line naming it (exit 2); a live viewer
    whose file becomes one keeps showing what it read (it printed a traceback)."""
    results_file = run_copy / "results.jsonl"
    with ViewerServer(Pages.create(Catalog([run_copy]), live=True), 0) as server:
        results_file.rename(tmp_path / "results.jsonl")
        results_file.mkdir()
        answer = send(server.port, "/")
        assert answer.status == 200
        assert len(listed(answer.raw.partition(b"\r\n\r\n")[2].decode())) == 8
        assert send(server.port, "/api/rows").status == 200
    assert main(["view", str(run_copy), "--export", str(tmp_path / "site")]) == 2
    err = capsys.readouterr().err
    assert err == f"cocobench: error: {results_file}: cannot read it (Is a directory)\n"


def test_prompts_inflating_past_the_bound_are_not_read(run_copy: Path,
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    """A `prompts.json.gz` is inflated up to `MAX_PROMPTS_BYTES` only (a compression bomb in
    a shared folder would exhaust the memory): past it, the page says no prompt was kept."""
    from cocobench_agents.runfolder import folder
    from cocobench_agents.viewer.timeline import NO_PROMPT

    pages = Pages.create(Catalog([run_copy]), live=False)
    episode = pages.catalog.episodes()[0]
    assert NO_PROMPT not in pages.episode(episode)
    monkeypatch.setattr(folder, "MAX_PROMPTS_BYTES", 1000)  # the real prompts inflate past it
    assert NO_PROMPT in pages.episode(episode)
