"""What a user of an evaluation CLI expects: instant help and mistakes (no LangGraph or
LiteLLM imported), keys from .env, help text on every option, flag names in messages, the
reference rows and legend of the first run, and a resumable Ctrl-C."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import click
import pytest

from cocobench_agents.cli import COMMANDS, cli, load_env_file, main
from cocobench_agents.runfolder.result_line import CS_NOTE
from tests.models.fake_openai import FakeOpenAI, ok

HEAVY = ("langgraph", "litellm")


def imports_during(argv: list[str], *, cwd: Path | None = None, env: dict | None = None
                   ) -> tuple[int, list[str], str]:
    """Run `cocobench argv` in a fresh interpreter: exit code, heavy modules it imported,
    and what it printed on stderr."""
    probe = ("import sys\nfrom cocobench_agents.cli import main\ncode = main(sys.argv[1:])\n"
             f"print('HEAVY', *[m for m in {HEAVY!r} if m in sys.modules], file=sys.stderr)\n"
             "sys.exit(code)")
    done = subprocess.run([sys.executable, "-c", probe, *argv], capture_output=True, text=True,
                          timeout=120, cwd=cwd, env=env)
    heavy_line = [line for line in done.stderr.splitlines() if line.startswith("HEAVY")][-1]
    assert "Traceback" not in done.stderr
    return done.returncode, heavy_line.split()[1:], done.stderr


def no_key_env() -> dict[str, str]:
    return {k: v for k, v in os.environ.items() if not k.endswith("_API_KEY")}


@pytest.mark.parametrize("argv", [["--help"], *([name, "--help"] for name in COMMANDS)])
def test_help_imports_no_model_stack(argv):
    code, heavy, _ = imports_during(argv)
    assert code == 0 and heavy == []


@pytest.mark.parametrize(("argv", "message"), [
    (["run", "--model", "openai/gpt-4o", "--out", "{out}"], "no API key: set OPENAI_API_KEY"),
    (["run", "--model", "anthropic/claude-sonnet-4-5", "--out", "{out}"], "ANTHROPIC_API_KEY"),
    (["run", "--model", "gpt4o-typo", "--out", "{out}"], "unknown model"),
    (["run", "--model", "greedy", "--out", "{out}", "--jobs", "zero"], "--jobs"),
    (["run", "--model", "greedy", "--out", "{out}", "--api-key-env", "sk-123"],
     "--api-key-env (model_settings.api_key_env): must be the NAME"),
])
def test_user_mistakes_answer_without_the_model_stack(tmp_path, argv, message):
    out = tmp_path / "run"
    code, heavy, err = imports_during([a.format(out=out) for a in argv], env=no_key_env())
    assert code == 2 and heavy == []
    assert message in err
    assert not out.exists()  # nothing created for a mistake


def test_resuming_a_finished_run_imports_no_model_stack(tmp_path):
    out = tmp_path / "run"
    assert main(["run", "--model", "greedy", "--suite", "demo", "--limit", "1",
                 "--out", str(out)]) == 0
    code, heavy, _ = imports_during(["run", "--out", str(out), "--resume"])
    assert code == 0 and heavy == []


def test_keys_come_from_dotenv_without_overriding_the_environment(tmp_path, monkeypatch):
    (tmp_path / ".env").write_text("COCO_TEST_KEY_A=from-file\nCOCO_TEST_KEY_B=from-file\n")
    monkeypatch.delenv("COCO_TEST_KEY_A", raising=False)
    monkeypatch.setenv("COCO_TEST_KEY_B", "from-env")
    load_env_file(tmp_path)
    assert os.environ["COCO_TEST_KEY_A"] == "from-file"
    assert os.environ["COCO_TEST_KEY_B"] == "from-env"
    monkeypatch.delenv("COCO_TEST_KEY_A")


@pytest.mark.slow
def test_the_cli_reads_dotenv_in_the_working_directory(tmp_path):
    (tmp_path / ".env").write_text("OPENAI_API_KEY=sk-from-dotenv-123\n")
    out = tmp_path / "run"
    # With the key present the check passes and the run is planned; --limit 0 instances of a
    # filtered-out cell leaves nothing to call.
    _code, _, err = imports_during(["run", "--model", "openai/gpt-4o", "--suite", "demo",
                                   "--only-cell", "NO_SUCH", "--out", str(out)],
                                  cwd=tmp_path, env=no_key_env())
    assert "no API key" not in err
    assert "sk-from-dotenv-123" not in "".join(p.read_text() for p in out.rglob("*")
                                                if p.is_file())


def _options(command: click.Command):
    for param in command.params:
        if isinstance(param, click.Option) and not param.hidden:
            yield param


@pytest.mark.parametrize("name", list(COMMANDS))
def test_every_option_has_help_text(name):
    command = cli.get_command(click.Context(cli), name)
    commands = [command]
    if isinstance(command, click.Group):
        commands += [command.get_command(click.Context(command), n)
                     for n in command.list_commands(click.Context(command))]
    missing = [f"{c.name} {o.opts[0]}" for c in commands for o in _options(c) if not o.help]
    assert missing == []


def test_list_without_a_source_lists_the_default_suite(capsys):
    assert main(["list", "--json"]) == 0
    assert len(json.loads(capsys.readouterr().out)) == 240


def test_baselines_add_the_oracle_and_built_ins_with_a_legend(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["run", "--model", "greedy", "--baselines", "--suite", "demo", "--out",
                 str(out)]) == 0
    printed = capsys.readouterr().out
    rows = {tuple(line.split()[:2]) for line in printed.splitlines() if line.split()}
    assert {("greedy", "C0_image"), ("random", "C0_image"), ("oracle", "OR_image")} <= rows
    assert "not_engaged" in printed and "low_signal" in printed and "na_no_actions" in printed
    assert CS_NOTE in " ".join(printed.split())  # why a failing team can have CS 1.00
    oracle = next(line for line in printed.splitlines() if line.startswith("oracle"))
    assert oracle.split()[3] == "100.0%"  # the upper bound: the oracle solves every instance
    recorded = json.loads((out / "run.json").read_text())
    assert recorded["plan"]["models"] == ["greedy", "random"]
    assert recorded["plan"]["conditions"] == ["C0_image", "OR_image"]


#: The Ctrl-C run: one model call per episode; `FINISHED` episodes are answered, then the
#: model holds the next call (until the test releases it) so the signal lands mid-run.
CTRL_C_EPISODES, FINISHED, HELD_S = 10, 3, 300.0


@pytest.mark.slow
def test_ctrl_c_keeps_what_finished_and_says_how_to_resume(tmp_path):
    out = tmp_path / "run"
    results = out / "results.jsonl"
    with FakeOpenAI() as model:
        model.program(*[ok("REASON: go\nACTION: 1")] * FINISHED,
                      default=ok("REASON: go\nACTION: 1", delay_s=HELD_S))
        argv = [sys.executable, "-m", "cocobench_agents.cli", "run", "--suite", "cocobench-240",
                "--limit", str(CTRL_C_EPISODES), "--model", "openai/fake-model", "--api-base",
                model.base_url, "--no-preflight", "--max-steps", "1", "--jobs", "1",
                "--out", str(out)]
        process = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                   text=True)
        # The run cannot finish while the model holds a call: wait for that call and for the
        # finished episodes' lines, however slow the machine.
        deadline = time.monotonic() + 120
        while not (model.count > FINISHED and results.exists()
                   and len(results.read_text().splitlines()) == FINISHED):
            assert process.poll() is None, "the run ended before its held model call"
            assert time.monotonic() < deadline, "the run never reached its held model call"
            time.sleep(0.02)
        process.send_signal(signal.SIGINT)
        try:
            _, err = process.communicate(timeout=120)
        except subprocess.TimeoutExpired:
            process.kill()
            pytest.fail("Ctrl-C with a model call in flight did not stop the run in 120 s")
        assert process.returncode == 130, err
        assert "Traceback" not in err
        assert f"cocobench run --out {out} --resume" in err
        assert len(results.read_text().splitlines()) == FINISHED

        model.program(default=ok("REASON: go\nACTION: 1"))  # releases the held call
        resumed = subprocess.run([sys.executable, "-m", "cocobench_agents.cli", "run", "--out",
                                  str(out), "--resume"], capture_output=True, text=True,
                                 timeout=300)
    assert resumed.returncode == 0, resumed.stderr
    assert len(results.read_text().splitlines()) == CTRL_C_EPISODES
