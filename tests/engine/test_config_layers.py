"""Settings come from flags > COCOBENCH_RUN_* variables > a --config file (YAML or TOML) >
the recorded run (with --resume) > the defaults; a bad layer is exit 2 naming where."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from cocobench_agents.cli import main

RUN = ["run", "--suite", "demo", "--model", "greedy"]


def resolved(capsys, *argv: str) -> dict:
    assert main([*argv, "--print-config"]) == 0
    return yaml.safe_load(capsys.readouterr().out)


@pytest.fixture
def sweep(tmp_path) -> Path:
    path = tmp_path / "sweep.yaml"
    path.write_text("execution:\n  jobs: 3\nmodel_settings:\n  temperature: 0.5\n"
                    "epochs: 2\nmax_steps: 4\n")
    return path


def test_each_layer_wins_over_the_ones_below(tmp_path, capsys, monkeypatch, sweep):
    out = str(tmp_path / "run")
    assert resolved(capsys, *RUN, "--out", out)["execution"]["jobs"] == 8  # the default
    from_file = resolved(capsys, *RUN, "--out", out, "--config", str(sweep))
    assert from_file["execution"]["jobs"] == 3 and from_file["epochs"] == 2
    assert from_file["model_settings"]["temperature"] == 0.5
    monkeypatch.setenv("COCOBENCH_RUN_JOBS", "5")
    monkeypatch.setenv("COCOBENCH_RUN_TEMPERATURE", "0.7")
    from_env = resolved(capsys, *RUN, "--out", out, "--config", str(sweep))
    assert from_env["execution"]["jobs"] == 5 and from_env["model_settings"]["temperature"] == 0.7
    assert from_env["epochs"] == 2  # not in the environment: the file's
    from_flag = resolved(capsys, *RUN, "--out", out, "--config", str(sweep), "--jobs", "7")
    assert from_flag["execution"]["jobs"] == 7 and from_flag["max_steps"] == 4


def test_the_config_file_and_variables_can_name_everything(tmp_path, capsys, monkeypatch):
    toml = tmp_path / "sweep.toml"
    toml.write_text('models = ["greedy", "random:1"]\nout = "from-file"\n'
                    '[selection]\nsources = ["demo"]\nlimit = 2\n')
    assert resolved(capsys, "run", "--config", str(toml))["models"] == ["greedy", "random:1"]
    monkeypatch.setenv("COCOBENCH_RUN_MODEL", "random:2 random:3")  # repeatable: by spaces
    monkeypatch.setenv("COCOBENCH_RUN_CONFIG", str(toml))
    request = resolved(capsys, "run")
    assert request["models"] == ["random:2", "random:3"]
    assert request["selection"] == {**request["selection"], "sources": ["demo"], "limit": 2}


@pytest.mark.parametrize(("text", "suffix", "expected"), [
    ("models: [greedy\n", ".yaml", "{path}: not YAML: "),
    ("models = [\n", ".toml", "{path}: not TOML: "),
    ("modles: [greedy]\n", ".yaml",
     "{path}: modles: not a setting of a run; did you mean models?"),
    ("execution: {jbos: 2}\n", ".yaml",
     "{path}: execution.jbos: not a setting of a run; did you mean execution.jobs?"),
    ("epochs: two\n", ".yaml", "{path}: epochs: Input should be a valid integer"),
    ("model_settings: {temperature: hot}\n", ".yaml", "{path}: model_settings.temperature:"),
    ("- a list\n", ".yaml", "{path}: expected a mapping of settings"),
    ("jobs: 2\n", ".json", "{path}: a config file must end in .yaml, .yml or .toml"),
])
def test_a_bad_config_file_is_exit_2_naming_file_and_key(tmp_path, capsys, text, suffix,
                                                         expected):
    path = tmp_path / f"sweep{suffix}"
    path.write_text(text)
    out = tmp_path / "run"
    assert main([*RUN, "--out", str(out), "--config", str(path)]) == 2
    err = capsys.readouterr().err
    assert expected.format(path=path) in err and "Traceback" not in err
    assert not out.exists()


def test_every_problem_is_one_line(tmp_path, capsys):
    path = tmp_path / "sweep.yaml"
    path.write_text("epochs: 0\nmax_steps: many\nmodels: [greedy]\nbogus: 1\n")
    assert main(["run", "--out", str(tmp_path / "run"), "--config", str(path)]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 3 and all(line.startswith("cocobench: error: ") for line in lines)
    assert [line.split(": ")[2] for line in lines] == [str(path)] * 3


def test_a_bad_flag_or_variable_names_itself(tmp_path, capsys, monkeypatch):
    out = str(tmp_path / "run")
    assert main([*RUN, "--out", out, "--temperature", "hot"]) == 2
    assert "--temperature (model_settings.temperature):" in capsys.readouterr().err
    monkeypatch.setenv("COCOBENCH_RUN_EPOCHS", "none")
    assert main([*RUN, "--out", out]) == 2
    assert "COCOBENCH_RUN_EPOCHS" in capsys.readouterr().err
    assert not Path(out).exists()


@pytest.mark.parametrize("choice, written, left_out", [
    (["--conditions", "C0_image,D1_blind"], {"conditions": ["C0_image", "D1_blind"]},
     {"planners", "obs_modes"}),
    (["--planner", "centralized", "--planner", "leader-worker", "--obs", "blind"],
     {"planners": ["centralized", "leader-worker"], "obs_modes": ["blind"]}, {"conditions"}),
])
def test_the_printed_config_runs_the_same_run(tmp_path, capsys, choice, written, left_out):
    flags = [*RUN, *choice, "--max-steps", "3", "--limit", "2",
             "--agent-model", "agent_2=random:1", "--temperature", "none"]
    assert main([*flags, "--out", str(tmp_path / "flags"), "--print-config"]) == 0
    config = tmp_path / "sweep.yaml"
    config.write_text(capsys.readouterr().out)
    printed = yaml.safe_load(config.read_text())
    # one form of the planner × observation choice: the one the request uses
    assert {k: printed[k] for k in written} == written and not left_out & printed.keys()
    assert not (tmp_path / "flags").exists()  # printing writes nothing
    assert main([*flags, "--out", str(tmp_path / "flags")]) == 0
    assert main(["run", "--config", str(config), "--out", str(tmp_path / "file")]) == 0

    def lines(folder: Path) -> list[dict]:
        return [{k: v for k, v in json.loads(line).items() if k != "elapsed_s"}
                for line in (folder / "results.jsonl").read_text().splitlines()]

    assert lines(tmp_path / "file") == lines(tmp_path / "flags")
    requests = [json.loads((tmp_path / name / "run.json").read_text())["request"]
                for name in ("flags", "file")]
    assert {**requests[0], "out": None} == {**requests[1], "out": None}


def test_resume_takes_the_recorded_request_under_the_new_flags(tmp_path, capsys):
    out = str(tmp_path / "run")
    assert main([*RUN, "--limit", "2", "--max-steps", "2", "--jobs", "1", "--out", out]) == 0
    capsys.readouterr()
    request = resolved(capsys, "run", "--out", out, "--resume", "--jobs", "4")
    assert request["max_steps"] == 2 and request["selection"]["limit"] == 2
    assert request["execution"]["jobs"] == 4
    assert main(["run", "--out", out, "--resume", "--temperature", "0.2"]) == 2
    err = capsys.readouterr().err
    assert ("--resume: model_settings.temperature (--temperature) 0.2 differs from the "
            'recorded run ("auto")') in err


def test_a_missing_or_unreadable_config_file_is_exit_2(tmp_path, capsys):
    out = tmp_path / "run"
    missing = tmp_path / "nope.yaml"
    assert main([*RUN, "--out", str(out), "--config", str(missing)]) == 2
    assert f"{missing}: no such config file" in capsys.readouterr().err
    binary = tmp_path / "sweep.yaml"
    binary.write_bytes(b"\xff\xfe\x00models")
    assert main([*RUN, "--out", str(out), "--config", str(binary)]) == 2
    assert f"{binary}: not UTF-8 text" in capsys.readouterr().err
    assert not out.exists()


def test_one_form_of_the_planner_choice_per_layer_and_the_upper_layer_decides(tmp_path, capsys):
    """``conditions`` replaces planners × observation modes: naming both in one layer is an
    error (one would be ignored); planners given over a file's conditions replace them."""
    out = ["--out", str(tmp_path / "run")]
    assert main([*RUN, *out, "--conditions", "C0_blind", "--planner", "leader-worker"]) == 2
    assert "--conditions and --planner/--obs both given" in capsys.readouterr().err
    both = tmp_path / "both.yaml"
    both.write_text("conditions: [C0_blind]\nobs_modes: [blind]\n")
    assert main([*RUN, *out, "--config", str(both)]) == 2
    assert f"{both}: conditions and planners/obs_modes both given" in capsys.readouterr().err
    assert not (tmp_path / "run").exists()
    sweep = tmp_path / "sweep.yaml"
    sweep.write_text("conditions: [C0_blind]\n")
    assert resolved(capsys, *RUN, *out, "--config", str(sweep))["conditions"] == ["C0_blind"]
    planned = resolved(capsys, *RUN, *out, "--config", str(sweep), "--planner", "leader-worker")
    assert planned["planners"] == ["leader-worker"] and "conditions" not in planned
    over = resolved(capsys, *RUN, *out, "--config", str(sweep), "--conditions", "D1_image")
    assert over["conditions"] == ["D1_image"]
