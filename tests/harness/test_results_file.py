"""What resume and report make of a damaged run folder: every invalid line and missing
trajectory is named (file and line, one line each, never a traceback); an episode whose line
is invalid or whose trajectory is missing counts as not done and runs again; a torn last
line is repaired with a warning; a junk run.json is a one-line error, exit 2."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from cocobench_agents.cli import main
from cocobench_agents.reports import load_runs
from cocobench_agents.runfolder.episode_key import EpisodeKey
from cocobench_agents.runfolder.errors import RunFolderError
from cocobench_agents.runfolder.folder import RunFolder
from cocobench_agents.tools import prompt_hash

RUN = ["run", "--suite", "demo", "--model", "greedy", "--conditions", "all", "--jobs", "4"]


@pytest.fixture(scope="module")
def complete_run(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("runs") / "complete"
    assert main([*RUN, "--out", str(out)]) == 0
    return out


@pytest.fixture()
def run(complete_run, tmp_path) -> Path:
    return Path(shutil.copytree(complete_run, tmp_path / "run"))


def lines(run: Path) -> list[str]:
    return (run / "results.jsonl").read_text().splitlines(keepends=True)


def write_lines(run: Path, text: list[str]) -> None:
    (run / "results.jsonl").write_text("".join(text))


def resume(run: Path, capfd) -> tuple[int, str]:
    code = main(["run", "--out", str(run), "--resume"])
    return code, capfd.readouterr().err


def done_episodes(run: Path) -> set[tuple]:
    return {(r["model"], r["condition"], r["task_id"]) for r in RunFolder(run).results()}


def test_junk_lines_are_named_and_their_episodes_run_again(run, capfd):
    text = lines(run)
    identified = json.loads(text[5])
    text[2] = "{this is not json\n"  # episode lost: it runs again
    text[5] = json.dumps({**identified, "task_success": "yes"}) + "\n"  # identifiable
    text.insert(8, json.dumps({**identified, "model": 123}) + "\n")  # names no episode
    text.insert(9, "[1, 2]\n")
    write_lines(run, text)
    code, err = resume(run, capfd)
    assert code == 0 and "Traceback" not in err
    results = run / "results.jsonl"
    assert f"warning: {results} line 3: not JSON (" in err
    assert (f"warning: {results} line 6: invalid result: task_success: Input should be a "
            f"valid integer; episode greedy {identified['condition']} "
            f"{identified['task_id']} counts as not done") in err
    assert "line 9: invalid result: model: Input should be a valid string; skipped" in err
    assert "line 10: not a result (a JSON list, not an object); skipped" in err
    assert "(22 already done)" in err  # lines 3 and 6 are run again, nothing else
    assert len(done_episodes(run)) == 24


def test_a_folder_reads_its_results_again_only_once_they_changed(run):
    """One read per state of the file, however often a resume asks: an append, a rewrite of
    the same length or a junk line is seen at once, and what one caller does to its scan
    does not reach the next."""
    folder = RunFolder(run)
    first = folder.scan_results()
    first.rows.clear()
    first.latest.clear()
    again = folder.scan_results()
    assert len(again.rows) == len(lines(run)) == len(again.latest) > 0
    assert folder.scan_results(check_trajectories=True).missing == []
    text = lines(run)
    write_lines(run, [*text, "junk\n"])
    scan = folder.scan_results()
    assert scan.invalid_lines == 1 and len(scan.rows) == len(text)
    record = json.loads(text[0])
    swapped = json.dumps({**record, "task_success": 1 - record["task_success"]})
    write_lines(run, [swapped + " " * (len(text[0]) - len(swapped) - 1) + "\n", *text[1:]])
    assert (run / "results.jsonl").stat().st_size == len("".join(text))
    assert folder.scan_results().rows[0]["task_success"] == 1 - record["task_success"]


def test_what_a_folder_appends_is_read_as_a_fresh_scan_reads_it(run, monkeypatch):
    """The run's own appends extend its scan (the summary reads nothing again), unless
    another writer's line came in between: then the whole file is read again."""
    from cocobench_agents.runfolder import json_lines

    folder, text = RunFolder(run), lines(run)
    folder.scan_results()
    folder.append_results([json.loads(text[0])])
    assert _rows(folder) == _rows(RunFolder(run)) and len([*folder.results()]) == len(text) + 1
    identity = json_lines.file_identity

    def foreign_line_after_the_first_look(fd):  # another process appends meanwhile
        seen = identity(fd)
        monkeypatch.setattr(json_lines, "file_identity", identity)
        with open(run / "results.jsonl", "a") as results:
            results.write(text[1])
        return seen

    monkeypatch.setattr(json_lines, "file_identity", foreign_line_after_the_first_look)
    folder.append_results([json.loads(text[2])])
    assert _rows(folder) == _rows(RunFolder(run)) and len([*folder.results()]) == len(text) + 3


def _rows(folder: RunFolder) -> tuple[list[str], list[str], list[str]]:
    """A scan's rows, latest lines (order included) and problems, comparable."""
    scan = folder.scan_results()
    return ([json.dumps(row, sort_keys=True) for row in scan.rows],
            [json.dumps([str(key), row], sort_keys=True) for key, row in scan.latest.items()],
            scan.problems)


def test_missing_trajectories_are_counted_past_the_shown_problems(run):
    """Ten problems are named one by one, the rest counted in one last line, whether they
    are bad lines or missing trajectories."""
    from cocobench_agents.runfolder.folder import SHOWN_PROBLEMS

    records = [json.loads(line) for line in lines(run)]
    for record in records:
        (run / record["trajectory"]).unlink()
    scan = RunFolder(run).scan_results(check_trajectories=True)
    assert len(scan.missing) == len(records) > SHOWN_PROBLEMS + 1
    assert len(scan.problems) == SHOWN_PROBLEMS + 1
    assert scan.problems[-1].endswith(f"{len(records) - SHOWN_PROBLEMS} more problems")


def test_a_torn_last_line_is_repaired_with_a_warning(run, capfd):
    text = lines(run)
    text[-1] = text[-1][:100]  # a kill in the middle of the last write
    write_lines(run, text)
    code, err = resume(run, capfd)
    assert code == 0
    assert "removed an incomplete last line (100 bytes" in err
    assert "(23 already done)" in err and len(done_episodes(run)) == 24
    assert RunFolder(run).scan_results().problems == []


def test_unreadable_results_are_a_one_line_error_and_nothing_is_lost(run, capfd):
    """A `results.jsonl` that is a folder (found by the run-folder fuzz: resume raised
    IsADirectoryError from cutting a torn tail) is named, exit 2; nothing is removed."""
    results = run / "results.jsonl"
    kept = results.read_bytes()
    results.unlink()
    results.mkdir()
    (results / "lines").write_bytes(kept)
    code, err = resume(run, capfd)
    assert code == 2 and "Traceback" not in err
    assert err == f"cocobench: error: {results}: unreadable (Is a directory)\n"
    assert (results / "lines").read_bytes() == kept


def test_a_missing_trajectory_is_named_and_its_episode_runs_again(run, capfd):
    first = json.loads(lines(run)[0])
    (run / first["trajectory"]).unlink()
    code, err = resume(run, capfd)
    assert code == 0
    assert f"warning: {run / first['trajectory']}: missing; episode greedy" in err
    assert "(23 already done)" in err
    assert (run / first["trajectory"]).is_file()
    # the retry supersedes the line whose trajectory was lost
    assert RunFolder(run).scan_results(check_trajectories=True).missing == []


def test_a_trajectory_path_outside_the_folder_counts_as_missing(run, capfd):
    text = lines(run)
    row = json.loads(text[0])
    text[0] = json.dumps({**row, "trajectory": "../../../etc/hostname"}) + "\n"
    write_lines(run, text)
    scan = RunFolder(run).scan_results(check_trajectories=True)
    assert [k.task_id for k in scan.missing] == [row["task_id"]]
    code, err = resume(run, capfd)
    assert code == 0 and "(23 already done)" in err


@pytest.mark.parametrize("junk", ["{not json", "[1, 2]", '{"plan": 3}', "[" * 100_000,
                                  b"\xff\xfe{}"])
def test_a_junk_run_json_is_a_one_line_error(run, capfd, junk):
    path = run / "run.json"
    path.write_bytes(junk if isinstance(junk, bytes) else junk.encode())
    code, err = resume(run, capfd)
    assert code == 2 and "Traceback" not in err
    assert err.startswith(f"cocobench: error: {path}: not a run record")
    assert len(err.splitlines()) == 1
    with pytest.raises(RunFolderError, match="not a run record"):
        RunFolder(run).run_record() if junk != '{"plan": 3}' else RunFolder(
            run).open_for_resume()


def test_the_report_validates_every_row_and_counts_what_it_skipped(run, capfd):
    text = lines(run)
    row = json.loads(text[0])
    text += [json.dumps({**row, "model": 123, "epoch": 1}) + "\n",  # not a second model
             json.dumps({**row, "epoch": 2, "construct_score": "high"}) + "\n",
             json.dumps({**row, "epoch": 3, "cross_construct": {"D1": 0.5}}) + "\n",
             "\n", "garbage\n"]
    write_lines(run, text)
    data = load_runs([run])
    assert data.models == ["greedy"] and len(data.episodes) == 24
    assert data.runs[0].invalid_lines == 5
    assert data.warnings == [f"{run / 'results.jsonl'}: 5 invalid result lines skipped (not "
                             "JSON, or not a valid result: `cocobench run --out RUN --resume` "
                             "names each and runs its episode again)"]
    assert main(["report", str(run), "--out", str(run / "report"), "--no-plots"]) == 0
    err = capfd.readouterr().err
    assert "warning: " in err and "5 invalid result lines skipped" in err
    index = (run / "report" / "index.md").read_text()
    assert "5 invalid lines skipped" in index and "> **Warning:**" in index


def test_the_report_notes_missing_trajectories(run):
    first = json.loads(lines(run)[0])
    (run / first["trajectory"]).unlink()
    data = load_runs([run])
    assert len(data.episodes) == 24  # the result line still counts in the report
    assert data.runs[0].missing_trajectories == 1


def test_every_prompt_is_kept_and_read_back(run):
    folder = RunFolder(run)
    sizes = {"prompts": 0, "trajectories": 0}
    for row in folder.results():
        key = EpisodeKey(row["model"], row["condition"], row["task_id"], row["epoch"])
        trajectory = json.loads((run / row["trajectory"]).read_text())
        assert "prompts" not in trajectory  # kept compressed beside it, not inline
        prompts = folder.prompts(key)
        calls = [d for d in trajectory["planner_decisions"] if "prompt_hash" in d]
        assert calls
        for decision in calls:
            text = folder.prompt(key, decision["prompt_hash"])
            assert text is not None
            assert prompt_hash(text) == decision["prompt_hash"]  # the very text sent
            assert folder.prompt(row, decision["prompt_hash"]) == text  # by its result line
        assert set(prompts) == {d["prompt_hash"] for d in calls}
        sizes["prompts"] += (run / Path(row["trajectory"]).parent / "prompts.json.gz"
                             ).stat().st_size
        sizes["trajectories"] += (run / row["trajectory"]).stat().st_size
    assert sizes["prompts"] < sizes["trajectories"] / 20


def test_prompts_of_something_not_a_result_line_are_refused_by_name(run):
    with pytest.raises(TypeError, match=r"an EpisodeKey or a result line .*KeyError: 'task_id'"):
        RunFolder(run).prompts({"model": "greedy", "condition": "C0_image"})


def test_a_folder_without_prompts_still_scores_reports_and_resumes(run, capfd):
    for path in run.glob("episodes/*/*/*/prompts.json.gz"):
        path.unlink()  # as written before prompts were kept
    row = next(RunFolder(run).results())
    key = EpisodeKey(row["model"], row["condition"], row["task_id"], row["epoch"])
    assert RunFolder(run).prompts(key) == {} and RunFolder(run).prompt(key, "0" * 16) is None
    assert main(["score", str(run / row["trajectory"])]) == 0
    assert main(["report", str(run), "--out", str(run / "report"), "--no-plots"]) == 0
    code, err = resume(run, capfd)
    assert code == 0 and "(24 already done)" in err and "warning" not in err


def test_nothing_of_an_episode_is_written_outside_the_run_folder(tmp_path):
    folder = RunFolder(tmp_path / "run")
    escaping = EpisodeKey("greedy", "C0_image", "../../../../outside")
    document = {"planner_decisions": [], "prompts": {"abc": "a prompt"}}
    with pytest.raises(RunFolderError, match="not inside the run folder"):
        folder.write_trajectory(escaping, document)
    with pytest.raises(RunFolderError, match="not inside the run folder"):
        folder.prompts(escaping)
    assert sorted(p.name for p in tmp_path.rglob("*")) == []
