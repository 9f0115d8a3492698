"""Bad inputs through the real commands: unfair or unsafe configs stop `list`/`validate`/`run`
with exit 2 before anything is written, subset files naming absent tasks follow `--missing`,
and `score` reports an unreadable trajectory in one line while scoring the others."""

from __future__ import annotations

import json
import shutil
from importlib import resources
from pathlib import Path

import pytest

from benchmark_adapter.oracles import run_oracle
from benchmark_adapter.tasks import load_task
from benchmark_adapter.trajectory import dumps
from cocobench_agents.cli import main

DEMO = Path(str(resources.files("benchmark_adapter") / "data" / "demo"))
G_D1 = "G_D1__DemoLivingRoom1__seed0"


def run(capsys, *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    return code, out, err


def config_file(folder: Path, name: str = G_D1, **changes) -> Path:
    config = json.loads((DEMO / f"{G_D1}.json").read_text(encoding="utf-8"))
    config.update(changes)
    path = folder / f"{name}.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(config), encoding="utf-8")
    return path


def files_under(folder: Path) -> set[Path]:
    return {p for p in folder.rglob("*") if p.is_file()}


# -- configs that cannot be a fair task -------------------------------------------------------

def test_an_escaping_task_id_stops_the_run_before_anything_is_written(capsys, tmp_path: Path
                                                                       ) -> None:
    evil = config_file(tmp_path / "tasks", "evil", task_id="../../../../escaped/x")
    before = files_under(tmp_path)
    code, _, err = run(capsys, "run", "--task", str(evil), "--model", "greedy",
                       "--out", str(tmp_path / "out" / "run"))
    assert code == 2
    assert err.strip() == (f"cocobench: error: {evil}: task_id: '../../../../escaped/x' is not "
                           "a safe task id: use 1 to 128 letters, digits, '_', '.' or '-', "
                           "starting with a letter or digit (it names the episode's folder)")
    assert files_under(tmp_path) == before  # no trajectory, no run record, anywhere


@pytest.mark.parametrize("command", ["list", "validate", "run"])
def test_a_team_that_does_not_match_its_size_is_refused(capsys, tmp_path: Path,
                                                        command: str) -> None:
    """Before: validate crashed ("not enough values to unpack"), run played one agent."""
    bad = config_file(tmp_path / "tasks", agent_count=1)
    extra = ["--model", "greedy", "--out", str(tmp_path / "run")] if command == "run" else []
    source = ["--task", str(bad)] if command == "run" else [str(bad)]
    code, out, err = run(capsys, command, *source, *extra)
    assert code == 2 and out == ""
    assert err.startswith(f"cocobench: error: {bad}: agent_count: 1, but 2 agents are listed")


def test_a_config_with_no_goals_is_refused(capsys, tmp_path: Path) -> None:
    """Before: greedy scored a 100% success rate on it."""
    bad = config_file(tmp_path, goal_predicates=[])
    code, _, err = run(capsys, "validate", str(bad))
    assert code == 2 and f"{bad}: goal_predicates: no goals" in err


# -- subset files naming absent tasks ---------------------------------------------------------

@pytest.fixture
def subset(tmp_path: Path) -> Path:
    """A reference-shaped tree: configs below the subset file's grandparent; one id absent."""
    shutil.copy(DEMO / f"{G_D1}.json", tmp_path / f"{G_D1}.json")
    path = tmp_path / "subsets" / "rep2.json"
    path.parent.mkdir()
    path.write_text(json.dumps({"name": "rep2", "task_ids": [G_D1, "gone__seed0"]}))
    return path


WARNING = "tasks not found under"


@pytest.mark.parametrize("command", ["list", "validate", "run"])
def test_missing_tasks_are_skipped_with_a_warning_by_default(capsys, tmp_path: Path,
                                                             subset: Path,
                                                             command: str) -> None:
    argv = {"list": ["list", str(subset)], "validate": ["validate", str(subset)],
            "run": ["run", "--suite", str(subset), "--model", "greedy", "--out",
                    str(tmp_path / "run"), "--obs", "blind"]}[command]
    code, out, err = run(capsys, *argv)
    assert code == 0
    assert (f"cocobench: warning: {subset}: task_ids: 1 of 2 {WARNING} {tmp_path} "
            "(e.g. gone__seed0); skipped them") in err
    assert G_D1 in out or command == "run"
    if command == "run":
        [line] = (tmp_path / "run" / "results.jsonl").read_text().splitlines()
        assert json.loads(line)["task_id"] == G_D1


@pytest.mark.parametrize("command", ["list", "validate", "run"])
def test_missing_error_refuses(capsys, tmp_path: Path, subset: Path, command: str) -> None:
    argv = {"list": ["list", str(subset)], "validate": ["validate", str(subset)],
            "run": ["run", "--suite", str(subset), "--model", "greedy", "--out",
                    str(tmp_path / "run")]}[command]
    code, out, err = run(capsys, *argv, "--missing", "error")
    assert code == 2 and out == ""
    assert f"{subset}: task_ids: 1 of 2 {WARNING}" in err and "--missing skip" in err
    assert not files_under(tmp_path / "run")


def test_missing_takes_only_skip_or_error(capsys, subset: Path) -> None:
    code, _, err = run(capsys, "list", str(subset), "--missing", "ignore")
    assert code == 2 and "--missing" in err


# -- score ------------------------------------------------------------------------------------

def test_score_reports_unreadable_files_in_one_line_and_scores_the_rest(capsys,
                                                                        tmp_path: Path) -> None:
    good = tmp_path / "good.json"
    good.write_text(dumps(run_oracle(load_task(DEMO / f"{G_D1}.json"))), encoding="utf-8")
    deep = tmp_path / "deep.json"
    deep.write_text('{"trajectory": ' + "[" * 100_000 + "]" * 100_000 + "}", encoding="utf-8")
    latin = tmp_path / "latin.json"
    latin.write_bytes(b'{"task_id": "caf\xe9"}')
    code, out, err = run(capsys, "score", str(deep), str(good), str(latin))
    assert code == 2
    assert [line.split()[0] for line in out.splitlines()[2:]] == [G_D1]
    assert err.splitlines() == [
        f"cocobench: error: {deep}: JSON nested too deeply to read",
        f"cocobench: error: {latin}: not UTF-8 text (byte 0xe9 at offset 16)",
    ]


# -- settings and config files that Python itself chokes on --------------------------------

@pytest.mark.parametrize(("variable", "value", "named"), [
    ("COCOBENCH_RUN_TEMPERATURE", "nan", "COCOBENCH_RUN_TEMPERATURE (--temperature, "),
    ("COCOBENCH_RUN_TIMEOUT", "inf", "COCOBENCH_RUN_TIMEOUT (--timeout, "),
    ("COCOBENCH_RUN_MAX_COST", "nan", "COCOBENCH_RUN_MAX_COST (--max-cost, "),
    ("COCOBENCH_RUN_EPISODE_TIMEOUT", "inf", "COCOBENCH_RUN_EPISODE_TIMEOUT (--episode-timeout, "),
    ("COCOBENCH_RUN_EXTRA", '{"top_p": NaN}', "COCOBENCH_RUN_EXTRA (--extra, "),
], ids=["temperature-nan", "timeout-inf", "max-cost-nan", "episode-timeout-inf", "extra-NaN"])
def test_a_setting_that_is_not_a_finite_number_is_refused(capsys, tmp_path: Path,
                                                          monkeypatch: pytest.MonkeyPatch,
                                                          variable: str, value: str,
                                                          named: str) -> None:
    # COCOBENCH_RUN_TEMPERATURE=nan was accepted: every call then failed as "transient".
    monkeypatch.setenv(variable, value)
    out = tmp_path / "run"
    code, _, err = run(capsys, "run", "--model", "openai/x", "--api-base",
                       "http://127.0.0.1:9/v1", "--task", str(DEMO / f"{G_D1}.json"),
                       "--out", str(out), "--dry-run")
    assert code == 2 and err.startswith(f"cocobench: error: {named}"), err
    assert len(err.strip().splitlines()) == 1 and not out.exists()


@pytest.mark.parametrize("text", [
    pytest.param("models: " + "[" * 10_000 + "]" * 10_000, marks=pytest.mark.slow),
    pytest.param("selection:\n  sources: " + "[" * 10_000 + "]" * 10_000,
                 marks=pytest.mark.slow),
    "models: " + "[" * 100 + "]" * 100,
    "".join(f"{' ' * i}k{i}:\n" for i in range(3_000)),
], ids=["list-10000", "nested-list-10000", "list-100", "mapping-3000"])
def test_a_config_file_nested_too_deep_is_one_line(capsys, tmp_path: Path, text: str) -> None:
    # A YAML file nested 10,000 deep was a RecursionError traceback.
    config = tmp_path / "deep.yaml"
    config.write_text(text)
    code, _, err = run(capsys, "run", "--config", str(config), "--model", "greedy",
                       "--out", str(tmp_path / "run"), "--dry-run")
    assert code == 2 and err.strip().splitlines() == [
        f"cocobench: error: {config}: nested more than 64 levels deep (a run's settings nest "
        "a few levels)"]


def alias_chain(links: int, depth: int) -> str:
    """YAML settings nesting `links` × `depth` levels through aliases, each anchor met first
    (the walk takes the last key first) where it is shallow: ``t1: *x1`` before ``x2``'s
    reference to it at depth `depth`."""
    def nest(inner: str) -> str:
        return "{a: " * depth + inner + "}" * depth

    lines = ["model_settings:", "  extra_params:", f"    x1: &x1 {nest('1')}"]
    lines += [f"    x{i}: &x{i} {nest(f'*x{i - 1}')}" for i in range(2, links + 1)]
    lines += [f"    t{i}: *x{i}" for i in range(links, 0, -1)]
    return "\n".join(lines) + "\n"


def test_a_config_file_nested_too_deep_through_aliases_is_one_line(capsys, tmp_path: Path
                                                                   ) -> None:
    # Each node was walked once, at the depth it was first met: 20 links of 60 (1,200 levels)
    # passed, and the run ended in pydantic's "Circular reference detected" traceback.
    config = tmp_path / "aliases.yaml"
    config.write_text(alias_chain(20, 60))
    code, _, err = run(capsys, "run", "--config", str(config), "--model", "greedy",
                       "--out", str(tmp_path / "run"), "--dry-run")
    assert code == 2 and err.strip().splitlines() == [
        f"cocobench: error: {config}: nested more than 64 levels deep (a run's settings nest "
        "a few levels)"]


def test_the_depth_of_shared_nodes_is_walked_in_bounded_time() -> None:
    from benchmark_adapter.tasks.loading import depth_exceeds

    laughs: list = ["lol"] * 10
    for _ in range(30):  # 10^30 leaves as a tree; 31 lists, each walked a few times
        laughs = [laughs] * 10
    assert not depth_exceeds(laughs, 64) and depth_exceeds(laughs, 30)


def test_a_toml_config_file_nested_too_deep_is_one_line(capsys, tmp_path: Path) -> None:
    config = tmp_path / "deep.toml"
    config.write_text("models = " + "[" * 10_000 + "]" * 10_000)
    code, _, err = run(capsys, "run", "--config", str(config), "--out", str(tmp_path / "r"),
                       "--dry-run")
    assert code == 2 and f"{config}: nested more than 64 levels" in err


@pytest.mark.parametrize("command", ["validate", "list", "run"])
def test_an_integer_too_long_for_python_is_refused_naming_its_field(capsys, tmp_path: Path,
                                                                    command: str) -> None:
    # 5,000 digits: json raised "Exceeds the limit (4300 digits) for integer string
    # conversion" from deep inside the decoder, a traceback.
    config = tmp_path / "tasks" / "long.json"
    config.parent.mkdir()
    config.write_text((DEMO / f"{G_D1}.json").read_text(encoding="utf-8").replace(
        '"seed": 0', '"seed": ' + "9" * 5_000, 1), encoding="utf-8")
    assert "9" * 5_000 in config.read_text()
    given = (("--task", str(config), "--model", "greedy", "--out", str(tmp_path / "run"))
             if command == "run" else (str(config),))
    code, _, err = run(capsys, command, *given)
    assert code == 2 and err.strip() == (f"cocobench: error: {config}: seed: an integer of "
                                         "5000 digits (Python converts at most 4300)")
    assert not (tmp_path / "run").exists()
