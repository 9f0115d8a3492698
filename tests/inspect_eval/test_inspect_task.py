"""CoCoBench as an Inspect task: the same episodes and scores through `inspect eval` as through
`cocobench run`, the task from the command line and from Python, the log's samples and scores,
bad parameters, and a provider failure recorded as the sample's infrastructure error."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

from .conftest import REPLIES, config_paths, inspect_command, scripted_mockllm, subprocess_env

pytestmark = pytest.mark.needs_inspect

CONDITIONS = "C0_image,C0_blind,D0_image,D0_blind,D1_image,D1_blind"
MAX_STEPS = 12
#: Fields of a result line that describe how the episode ran, not what it scored: the model's
#: name, wall time, where the trajectory lies, and token usage (mockllm counts tokens, a
#: scripted client spends none).
RUN_FIELDS = {"models", "model", "elapsed_s", "trajectory", "usage"}


def _inspect_eval(tmp_path: Path, replies: list[str], **task_args):
    from inspect_ai import eval as inspect_eval

    from cocobench_agents.inspect_eval.task import cocobench

    team = scripted_mockllm(replies)
    roles = {f"agent_{i}": scripted_mockllm(replies) for i in (1, 2, 3)}
    [log] = inspect_eval(cocobench(**task_args), model=team, model_roles=roles,
                         log_dir=str(tmp_path / "logs"), display="none", max_samples=4)
    return log


def _same(a: object, b: object) -> bool:
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return a == b


def test_inspect_and_cocobench_run_score_every_episode_alike(tmp_path: Path):
    from inspect_ai.log import read_eval_log

    from cocobench_agents.inspect_eval.scorer import score_values
    from cocobench_agents.inspect_eval.solver import RESULT, TRAJECTORY

    script = tmp_path / "replies.json"
    script.write_text(json.dumps(REPLIES))
    # `cocobench run` as a user runs it: its own process, whose workers fork from it (not
    # from this test process, which holds Inspect, torch and the rest by now).
    tasks = [arg for path in config_paths() for arg in ("--task", path)]
    done = subprocess.run(
        [sys.executable, "-m", "cocobench_agents.cli", "run", *tasks, "--model",
         f"scripted:{script}", "--conditions", CONDITIONS, "--max-steps", str(MAX_STEPS),
         "--out", str(tmp_path / "run")],
        capture_output=True, text=True, env=subprocess_env(), timeout=600, check=False)
    assert done.returncode == 0, done.stderr[-3000:]
    lines = {(r["condition"], r["task_id"], r["epoch"]): r
             for r in map(json.loads, (tmp_path / "run" / "results.jsonl").read_text()
                          .splitlines())}
    assert len(lines) == 12
    assert not [r["infra_error"] for r in lines.values() if r.get("infra_error")]

    log = read_eval_log(_inspect_eval(tmp_path, REPLIES, task=config_paths(),
                                      conditions=CONDITIONS, max_steps=MAX_STEPS).location)
    assert log.status == "success", log.error
    assert len(log.samples) == 12
    for sample in log.samples:
        line = sample.store[RESULT]
        key = (line["condition"], line["task_id"], sample.epoch - 1)
        theirs = lines.pop(key)
        scores = sample.scores["cocobench_scorer"].value
        expected = score_values(theirs)
        assert all(_same(scores[k], expected[k]) for k in expected), (key, scores, expected)
        assert {k: v for k, v in line.items() if k not in RUN_FIELDS} == \
               {k: v for k, v in theirs.items() if k not in RUN_FIELDS}, key
        # the same decisions, reply by reply
        trajectory = json.loads((tmp_path / "run" / theirs["trajectory"]).read_text())
        assert [d.get("raw_output") for d in sample.store[TRAJECTORY]["planner_decisions"]] \
            == [d.get("raw_output") for d in trajectory["planner_decisions"]], key
        # each decision is a model event of Inspect's transcript
        calls = [d for d in trajectory["planner_decisions"] if d.get("raw_output") is not None]
        events = [e for e in sample.events if e.event == "model"]
        assert len(events) == len(calls), key
        # a decentralized team's agents decide with the model roles named after them
        roles = {e.role for e in events}
        assert roles == ({None} if key[0].startswith("C0") else {"agent_1", "agent_2", "agent_3"}
                         if "3agent" in key[1] else {"agent_1", "agent_2"}), (key, roles)
    assert not lines
    # the comparison is not vacuous: the episodes differ in what they scored, and some
    # construct scores are unscored (NaN), some scored
    values = [s.scores["cocobench_scorer"].value for s in log.samples]
    assert len({v["progress"] for v in values}) > 1
    assert {math.isnan(v["construct_score"]) for v in values} == {True, False}


def test_images_go_as_inspect_image_content(tmp_path: Path):
    from inspect_ai.log import read_eval_log
    from inspect_ai.model import ContentImage

    log = read_eval_log(_inspect_eval(tmp_path, REPLIES, task=config_paths()[0],
                                      conditions="C0_image,C0_blind", max_steps=2).location,
                        resolve_attachments=True)
    for sample in log.samples:
        [first, *_] = [e for e in sample.events if e.event == "model"]
        content = first.input[0].content
        images = [c for c in content if isinstance(c, ContentImage)] if isinstance(
            content, list) else []
        if sample.id.startswith("C0_image"):
            assert images and all(c.image.startswith("data:image/png;base64,") for c in images)
        else:
            assert not images


def test_the_construct_score_counts_scored_episodes_only(tmp_path: Path):
    from inspect_ai.log import read_eval_log

    log = read_eval_log(_inspect_eval(tmp_path, REPLIES, task=config_paths(),
                                      conditions="C0_blind", max_steps=MAX_STEPS).location)
    values = [s.scores["cocobench_scorer"].value for s in log.samples]
    scored = [v["construct_score"] for v in values if not math.isnan(v["construct_score"])]
    dims = {s.metadata["dim"] for s in log.samples}
    assert dims == {"D1", "D2"}
    metrics = {score.name: score for score in log.results.scores}
    cs = metrics["construct_score"]
    assert cs.scored_samples == len(scored)
    assert cs.metrics["mean"].value == pytest.approx(sum(scored) / len(scored))
    assert set(cs.metrics) == {"mean", "bootstrap_stderr"}
    # each dimension's construct score is an episode's of that dimension only
    assert metrics["cs_D2"].scored_samples <= sum(v["cs_D2"] == v["cs_D2"] for v in values)
    assert metrics["success"].scored_samples == len(values)


@pytest.mark.parametrize(("args", "message"), [
    ({"max_steps": 0}, "-T max_steps: Input should be greater than or equal to 1"),
    ({"conditions": "X9_image"}, "unknown condition 'X9_image'"),
    ({"epochs": 2}, "-T epochs: Inspect sets this for a CoCoBench task; use --epochs N"),
    ({"frobnicate": 1}, "-T frobnicate: no such parameter"),
    ({"cache_dir": "/tmp/c"}, "-T cache_dir: Inspect sets this for a CoCoBench task"),
    ({"task": "/nonexistent/tasks"}, "/nonexistent/tasks"),
])
def test_bad_parameters_stop_the_run_before_any_sample(tmp_path: Path, args, message):
    from inspect_ai import eval as inspect_eval

    from cocobench_agents.inspect_eval.params import TaskParameterError
    from cocobench_agents.inspect_eval.task import cocobench

    with pytest.raises(TaskParameterError) as caught:
        inspect_eval(cocobench, task_args=args, model="mockllm/model", log_dir=str(tmp_path),
                     display="none")
    assert message in str(caught.value)
    assert not list(tmp_path.glob("*.eval"))  # no log, no sample ran


def test_a_provider_failure_is_the_samples_infrastructure_error(tmp_path: Path):
    from inspect_ai import eval as inspect_eval
    from inspect_ai.log import read_eval_log
    from inspect_ai.model import get_model

    from cocobench_agents.inspect_eval.solver import TRAJECTORY
    from cocobench_agents.inspect_eval.task import cocobench
    from cocobench_agents.runfolder.folder import RunFolder

    class Unavailable(Exception):
        status_code = 503

    def fail(*_):
        raise Unavailable("the provider is down")

    model = get_model("mockllm/model", custom_outputs=fail, memoize=False)
    [log] = inspect_eval(cocobench(task=config_paths()[0], conditions="C0_blind",
                                   max_steps=2),
                         model=model, log_dir=str(tmp_path), display="none",
                         fail_on_error=False)
    [sample] = read_eval_log(log.location).samples
    assert sample.error is not None
    assert "got no answer after Inspect's retries (transient)" in sample.error.message
    assert "the provider is down" in sample.error.message
    assert not sample.scores  # no score: not a model failure
    decisions = sample.store[TRAJECTORY]["planner_decisions"]
    assert decisions[0]["status"] == "backend_error"
    # imported, the sample is an infrastructure error's line with its trajectory
    out = tmp_path / "imported"
    done = _import(log.location, out)
    assert done.returncode == 0, done.stderr
    assert "1 episodes, 1 infrastructure errors" in done.stdout
    [line] = RunFolder(out).results()
    assert line["infra_error"] and "the provider is down" in line["infra_error"]
    written = json.loads((out / line["trajectory"]).read_text())
    assert written["planner_decisions"][0]["status"] == "backend_error"


def _import(log: str, out: Path) -> subprocess.CompletedProcess[str]:
    """`cocobench import-inspect LOG --out OUT`."""
    return subprocess.run(
        [sys.executable, "-m", "cocobench_agents.cli", "import-inspect", log, "--out",
         str(out)], capture_output=True, text=True, env=subprocess_env(), check=False)


def test_the_task_runs_from_the_command_line(tmp_path: Path):
    """`inspect eval cocobench_agents/cocobench`, found through the `inspect_ai` entry point
    of the installed package."""
    from inspect_ai.log import list_eval_logs, read_eval_log

    done = subprocess.run(
        [*inspect_command(), "eval", "cocobench_agents/cocobench", "--model", "mockllm/model",
         "-T", f"task={config_paths()[0]}", "-T", "conditions=D1_image,C0_blind",
         "-T", "max_steps=2", "--epochs", "2", "--log-dir", str(tmp_path),
         "--display", "none"],
        capture_output=True, text=True, env=subprocess_env(checkout_first=False), timeout=300,
        check=False)
    assert done.returncode == 0, done.stderr[-3000:]
    [info] = list_eval_logs(str(tmp_path))
    log = read_eval_log(info)
    assert log.eval.task == "cocobench_agents/cocobench"
    assert sorted((s.id, s.epoch) for s in log.samples) == sorted(
        (f"{c}/A_D1__FloorPlan1__seed0", e) for c in ("D1_image", "C0_blind") for e in (1, 2))
    for sample in log.samples:
        value = sample.scores["cocobench_scorer"].value
        assert set(value) >= {"success", "construct_score", "legal_plan", "progress", "steps"}
        assert value["steps"] <= 2


def test_a_bad_parameter_on_the_command_line_names_it(tmp_path: Path):
    done = subprocess.run(
        [*inspect_command(), "eval", "cocobench_agents/cocobench", "--model", "mockllm/model",
         "-T", "max_steps=0", "--log-dir", str(tmp_path)],
        capture_output=True, text=True, env=subprocess_env(checkout_first=False), timeout=300,
        check=False)
    assert done.returncode == 1
    # our message alone, not a traceback
    assert done.stdout.strip() == "-T max_steps: Input should be greater than or equal to 1"
    assert "Traceback" not in done.stderr
    assert not list(tmp_path.glob("*.eval"))



def test_an_inspect_log_becomes_a_run_folder_the_viewer_reads(tmp_path: Path):
    from cocobench_agents.runfolder.folder import RunFolder

    log = _inspect_eval(tmp_path, REPLIES, task=config_paths(), conditions="D1_image,C0_blind",
                        max_steps=3)
    out = tmp_path / "imported"
    done = subprocess.run(
        [sys.executable, "-m", "cocobench_agents.cli", "import-inspect", log.location,
         "--out", str(out)], capture_output=True, text=True, env=subprocess_env(), check=False)
    assert done.returncode == 0, done.stderr
    assert f"cocobench view {out}" in done.stdout
    lines = list(RunFolder(out).results())
    assert len(lines) == 4 and all(line["model"] == "mockllm/model" for line in lines)
    for line in lines:  # `cocobench score` rescoring the written trajectory gives the line
        scored = subprocess.run(
            [sys.executable, "-m", "cocobench_agents.cli", "score", "--json",
             str(out / line["trajectory"])], capture_output=True, text=True,
            env=subprocess_env(), check=True)
        [rescored] = json.loads(scored.stdout)
        assert rescored["construct_score"] == line["construct_score"]
        assert rescored["num_steps"] == line["num_steps"]
    # the viewer shows each episode with its construct signal and timeline
    site = tmp_path / "site"
    viewed = subprocess.run(
        [sys.executable, "-m", "cocobench_agents.cli", "view", str(out), "--export", str(site)],
        capture_output=True, text=True, env=subprocess_env(), check=False)
    assert viewed.returncode == 0, viewed.stderr
    pages = [p.read_text() for p in site.rglob("*.html") if "D1_image" in str(p)
             or "C0_blind" in str(p)]
    episodes = [html for html in pages if "landed steps" in html]
    assert len(episodes) == 4
    assert all("<svg" in html and "construct" in html.lower() for html in episodes)
    # a second import into the same folder, or a file that is not a log: one line, exit 2
    again = subprocess.run(
        [sys.executable, "-m", "cocobench_agents.cli", "import-inspect", log.location,
         "--out", str(out)], capture_output=True, text=True, env=subprocess_env(), check=False)
    assert again.returncode == 2 and "already holds a run" in again.stderr
    bad = subprocess.run(
        [sys.executable, "-m", "cocobench_agents.cli", "import-inspect",
         str(out / "run.json"), "--out", str(tmp_path / "other")],
        capture_output=True, text=True, env=subprocess_env(), check=False)
    assert bad.returncode == 2 and "not an Inspect log" in bad.stderr, bad.stderr
    assert "Traceback" not in bad.stderr


def test_a_log_with_a_sample_the_request_lacks_writes_no_run_folder(tmp_path: Path):
    from inspect_ai.log import read_eval_log, write_eval_log

    from cocobench_agents.runfolder.folder import RunFolder

    log = read_eval_log(_inspect_eval(tmp_path, REPLIES, task=config_paths()[0],
                                      conditions="C0_blind,D1_blind", max_steps=2).location)
    stray = tmp_path / "stray.eval"
    log.samples[-1].id = "D2_blind/A_D1__FloorPlan1__seed0"  # not a requested condition
    write_eval_log(log, str(stray))
    out = tmp_path / "imported"
    done = _import(str(stray), out)
    assert done.returncode == 2, done.stderr
    assert "'D2_blind/A_D1__FloorPlan1__seed0' (epoch 1) is not an episode of the recorded " \
           "request" in done.stderr
    assert "Traceback" not in done.stderr
    assert not out.exists()  # checked before anything was written
    # the folder is free for the log as Inspect wrote it
    done = _import(log.location, out)
    assert done.returncode == 0, done.stderr
    assert len(list(RunFolder(out).results())) == 2


def test_a_full_disk_leaves_no_half_imported_folder(tmp_path: Path):
    """A file size limit makes writes fail as a full disk does (EFBIG), once the folder and
    its run.json are made: the import ends in one line, exit 1, and takes back what it wrote,
    so the same command completes once there is room."""
    import resource
    import signal

    from cocobench_agents.runfolder.folder import RunFolder

    log = _inspect_eval(tmp_path, REPLIES, task=config_paths()[0],
                        conditions="C0_blind,D1_blind", max_steps=2).location

    def small_files() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # fail the write, not the process
        resource.setrlimit(resource.RLIMIT_FSIZE, (9000, 9000))

    out = tmp_path / "imported"
    full = subprocess.run(
        [sys.executable, "-m", "cocobench_agents.cli", "import-inspect", log, "--out",
         str(out)], capture_output=True, text=True, env=subprocess_env(), check=False,
        preexec_fn=small_files)
    assert full.returncode == 1, full.stderr
    assert "File too large" in full.stderr and "Traceback" not in full.stderr, full.stderr
    assert not out.exists()
    done = _import(log, out)
    assert done.returncode == 0, done.stderr
    assert len(list(RunFolder(out).results())) == 2


def test_an_inspect_usage_limit_ends_the_sample_scored_as_it_stands(tmp_path: Path):
    from inspect_ai import eval as inspect_eval
    from inspect_ai.log import read_eval_log

    from cocobench_agents.inspect_eval.scorer import score_values
    from cocobench_agents.inspect_eval.task import cocobench
    from cocobench_agents.runfolder.folder import RunFolder
    from cocobench_agents.runfolder.infra import is_infra_failure

    [log] = inspect_eval(cocobench(task=config_paths()[0], conditions="C0_blind,D1_blind"),
                         model=scripted_mockllm(REPLIES), log_dir=str(tmp_path),
                         display="none", token_limit=5000)
    log = read_eval_log(log.location)
    assert log.status == "success"
    for sample in log.samples:
        assert sample.error is None and sample.limit is not None
        assert sample.limit.type == "token"
        steps = sample.scores["cocobench_scorer"].value["steps"]
        assert 0 < steps < 12  # the budget is 22: the limit stopped it
        # labelled as a usage limit, not as a planner's failure
        assert sample.scores["cocobench_scorer"].metadata["terminal_reason"] == "usage_limit"
    # imported, each sample is a normal result line, scored as Inspect scored it
    out = tmp_path / "imported"
    done = _import(log.location, out)
    assert done.returncode == 0, done.stderr
    assert "infrastructure errors" not in done.stdout
    lines = {(line["condition"], line["epoch"]): line for line in RunFolder(out).results()}
    assert len(lines) == len(log.samples)
    for sample in log.samples:
        line = lines[(sample.id.partition("/")[0], sample.epoch - 1)]
        assert not is_infra_failure(line), line
        assert line["model"] == "mockllm/model" and (out / line["trajectory"]).is_file()
        scores = sample.scores["cocobench_scorer"].value
        expected = score_values(line)
        assert all(_same(scores[k], expected[k]) for k in expected), (line, scores)


def test_an_imported_run_names_its_log_and_how_it_ran(tmp_path: Path):
    """run.json of an import: the source log, the command that runs the eval again (run here),
    Inspect's transport; each line's wall time; an interrupted log is told as incomplete,
    with the commands that complete it."""
    import shlex

    from inspect_ai.log import read_eval_log, write_eval_log

    from cocobench_agents.runfolder.folder import RunFolder

    log = _inspect_eval(tmp_path, REPLIES, task=config_paths()[0], conditions="C0_blind",
                        max_steps=2).location
    out = tmp_path / "imported"
    done = _import(log, out)
    assert done.returncode == 0 and "warning" not in done.stderr, done.stderr
    record = json.loads((out / "run.json").read_text())
    assert record["imported_from"]["inspect_log"] == str(Path(log).resolve())
    assert record["imported_from"]["status"] == "success"
    assert record["request"]["model_settings"]["transport"] == "inspect"
    assert all(line["elapsed_s"] > 0 for line in RunFolder(out).results())
    command = shlex.split(record["command"])
    assert command[:5] == ["inspect", "eval", "cocobench_agents/cocobench", "--model",
                           "mockllm/model"]
    again = subprocess.run([*inspect_command(), *command[1:], "--log-dir",
                            str(tmp_path / "again"), "--display", "plain"],
                           capture_output=True, text=True, env=subprocess_env(
                               checkout_first=False), timeout=300, check=False)
    assert again.returncode == 0, again.stdout[-2000:] + again.stderr[-2000:]
    [rerun] = [read_eval_log(str(p)) for p in (tmp_path / "again").glob("*.eval")]
    assert [s.id for s in rerun.samples] == [s.id for s in read_eval_log(log).samples]
    # a log Ctrl-C ended: imported, and told as incomplete with Inspect's retry
    interrupted = read_eval_log(log)
    interrupted.status = "cancelled"
    write_eval_log(interrupted, str(tmp_path / "cancelled.eval"))
    done = _import(str(tmp_path / "cancelled.eval"), tmp_path / "partial")
    assert done.returncode == 0, done.stderr
    assert "the eval is incomplete (the log's status: cancelled)" in done.stderr
    assert f"inspect eval-retry {tmp_path / 'cancelled.eval'}, then cocobench " \
           "import-inspect NEW_LOG" in done.stderr
