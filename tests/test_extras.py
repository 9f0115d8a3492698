"""The one place that skips tests needing an extra (tests/conftest.py): a marked test skips,
with the reason and the install command, exactly when its extra is missing; the markers are
registered; `--fail-on-skip` fails a session in which anything skipped; CI runs the README's
test command first, as a newcomer does, then the suite with every extra and no skip."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

import tests.conftest as extras

pytest_plugins = ["pytester"]

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def session(pytester: pytest.Pytester, monkeypatch: pytest.MonkeyPatch) -> pytest.Pytester:
    """A pytest session in a temporary folder whose conftest is the project's (and no
    installed plugin: they take seconds to load)."""
    monkeypatch.setenv("PYTEST_DISABLE_PLUGIN_AUTOLOAD", "1")
    pytester.makeconftest("from tests.conftest import *  # noqa: F403\n")
    return pytester


def hide_module(name: str):
    return lambda monkeypatch: monkeypatch.setitem(sys.modules, name, None)


HIDE = {
    "needs_ray": (hide_module("ray"), "ray is not installed (pip install -e '.[ray]')"),
    "needs_thor": (hide_module("ai2thor"), "ai2thor is not installed (pip install -e '.[thor]')"),
    "needs_env": (hide_module("pettingzoo"),
                  "pettingzoo is not installed (pip install -e '.[env]')"),
    "needs_trl": (hide_module("trl"), "trl is not installed (pip install -e '.[env,trl]')"),
    "needs_browser": (lambda monkeypatch: monkeypatch.setenv("PATH", ""),
                      "Debian's chromium is not installed (apt-get install chromium)"),
    "needs_langgraph_cli": (
        lambda monkeypatch: monkeypatch.setattr(extras, "LANGGRAPH_CLI", Path("/nonexistent")),
        "langgraph-cli is not installed (pip install 'langgraph-cli[inmem]"),
    "needs_inspect": (hide_module("inspect_ai"),
                      "inspect_ai is not installed (pip install -e '.[inspect]')"),
    "llm": (hide_module("xllamacpp"), "xllamacpp is not installed (pip install xllamacpp)"),
    "vlm": (hide_module("gguf"), "gguf is not installed (pip install gguf==0.19.0)"),
    "needs_export": (hide_module("pyarrow"),
                     "pyarrow is not installed (pip install -e '.[export]' 'datasets>=4')"),
}


def test_every_extra_is_hidden_here_and_registered_in_pyproject(pytestconfig):
    registered = {line.split(":")[0] for line in pytestconfig.getini("markers")}
    markers = [extra.marker for extra in extras.EXTRAS]
    assert set(HIDE) == set(markers)
    assert set(markers) <= registered


@pytest.mark.parametrize("marker", list(HIDE))
def test_a_missing_extra_skips_only_its_tests_naming_the_install(session, monkeypatch, marker):
    hide, reason = HIDE[marker]
    hide(monkeypatch)
    session.makepyfile(f"""
        import pytest

        @pytest.mark.{marker}
        def test_needs_it():
            raise AssertionError("ran without its extra")

        def test_needs_nothing():
            pass
    """)
    result = session.runpytest("-rs")
    result.assert_outcomes(passed=1, skipped=1)
    assert reason in result.stdout.str()


def test_an_extra_that_is_there_runs_its_tests(session, monkeypatch):
    monkeypatch.setattr(extras, "EXTRAS", (extras.Extra("needs_ray", lambda: None),))
    session.makepyfile("""
        import pytest

        @pytest.mark.needs_ray
        def test_needs_it():
            pass
    """)
    session.runpytest().assert_outcomes(passed=1)


SKIPS_ONE = """
    import pytest

    def test_skipped():
        pytest.skip("not here")

    def test_passes():
        pass
"""


def test_fail_on_skip_fails_a_session_that_skipped(session):
    session.makepyfile(SKIPS_ONE)
    assert session.runpytest().ret == pytest.ExitCode.OK
    result = session.runpytest("--fail-on-skip")
    assert result.ret == pytest.ExitCode.TESTS_FAILED
    assert "--fail-on-skip: 1 tests skipped" in result.stdout.str()


def test_fail_on_skip_fails_a_parallel_session_whose_worker_skipped(session, monkeypatch):
    # Under xdist a worker skips; the controller, which sees its reports, fails the session.
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    session.makepyfile(SKIPS_ONE)
    result = session.runpytest("-p", "xdist", "-n", "1", "--fail-on-skip")
    assert result.ret == pytest.ExitCode.TESTS_FAILED
    assert "--fail-on-skip: 1 tests skipped" in result.stdout.str()


def test_fail_on_skip_passes_a_session_without_skips(session):
    session.makepyfile("def test_passes():\n    pass\n")
    assert session.runpytest("--fail-on-skip").ret == pytest.ExitCode.OK


def test_record_skipped_names_what_a_parallel_session_skipped(session, monkeypatch, tmp_path):
    # CI's first run records what skipped there; its run with every extra takes the file back.
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    session.makepyfile(SKIPS_ONE)
    record = tmp_path / "skipped.txt"
    result = session.runpytest("-p", "xdist", "-n", "1", "--record-skipped", str(record))
    result.assert_outcomes(passed=1, skipped=1)
    module = "test_record_skipped_names_what_a_parallel_session_skipped.py"
    assert record.read_text() == f"{module}::test_skipped\n"
    session.runpytest("-p", "xdist", "-n", "1", f"@{record}").assert_outcomes(skipped=1)


def test_no_test_skips_on_its_own_import():
    # Skips on a missing piece go through a marker (tests/conftest.py), never a module's own
    # importorskip: one place says what each extra is and how to install it.
    offenders = [str(path.relative_to(ROOT)) for path in (ROOT / "tests").rglob("*.py")
                 if path.name != "test_extras.py" and "importorskip(" in path.read_text()]
    assert offenders == []


README_TEST_COMMAND = "python -m pip install -e '.[dev]' && python -m pytest"


def test_ci_runs_the_readme_test_command_first_in_a_fresh_venv():
    readme = (ROOT / "README.md").read_text()
    ci = (ROOT / ".ci" / "run").read_text()
    assert README_TEST_COMMAND in readme
    fresh_venv, readme_command = ci.index("python -m venv"), ci.index(README_TEST_COMMAND)
    extras_installed = ci.index("pip_install -e '.[dev,thor,ray]'")
    assert fresh_venv < readme_command < extras_installed
    assert ci.index("python -m pytest --slow --fail-on-skip") > extras_installed


def test_the_processes_tests_start_hear_ctrl_c():
    # Even when the session was started with Ctrl-C ignored (in the background): tests that
    # interrupt a run send it SIGINT, as a person at a terminal would.
    probe = "import signal; print(signal.getsignal(signal.SIGINT) is signal.default_int_handler)"
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                          timeout=60)
    assert done.stdout.strip() == "True"


SLOW_ONE = """
import pytest

@pytest.mark.slow
def test_end_to_end():
    pass

def test_quick():
    pass
"""


@pytest.mark.parametrize("workers", [[], ["-p", "xdist", "-n", "1"]])
def test_a_slow_test_skips_saying_how_to_run_it(session, workers):
    # The README's bare command leaves the end-to-end tests to CI, and says so in the summary.
    session.makepyfile(SLOW_ONE)
    result = session.runpytest("-rs", *workers)
    result.assert_outcomes(passed=1, skipped=1)
    result.stdout.fnmatch_lines(["*marked slow: python -m pytest --slow runs it*"])


@pytest.mark.parametrize("asked", [["--slow"], ["-m", "slow"], ["-m", "slow or not slow"],
                                   ["NAMED"], ["-p", "xdist", "-n", "1", "NAMED"]])
def test_slow_tests_run_when_asked_for_or_named(session, asked):
    # A bare `pytest` skips them; naming a file (or a test) runs what it names.
    path = session.makepyfile(SLOW_ONE)
    asked = [str(path) if arg == "NAMED" else arg for arg in asked]
    outcomes = session.runpytest(*asked).parseoutcomes()
    assert outcomes.get("skipped", 0) == 0 and outcomes["passed"] == (1 if asked == ["-m", "slow"]
                                                                       else 2)


def test_ci_runs_the_slow_tests_the_readme_command_skipped(session, monkeypatch, tmp_path):
    # .ci/run: the README's command records what skipped; step 2 runs it with `--slow`.
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    session.makepyfile(SLOW_ONE)
    record = tmp_path / "skipped.txt"
    session.runpytest("-p", "xdist", "-n", "1", "--record-skipped", str(record))
    assert record.read_text().endswith("::test_end_to_end\n")
    session.runpytest("-p", "xdist", "-n", "1", "--slow", "--fail-on-skip",
                      f"@{record}").assert_outcomes(passed=1)
