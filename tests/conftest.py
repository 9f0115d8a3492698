"""Settings for the whole test session, and the one place that says which optional piece
(extra) each test needs.

A test that needs an extra carries its marker (`needs_ray`, `needs_thor`, `needs_browser`,
`needs_langgraph_cli`, `needs_export`, `needs_env`, `needs_trl`, `needs_inspect`, `llm`,
`vlm`); where that piece is missing, the test is skipped with the reason and the command that
installs it. Nothing else in the tests skips on a missing extra. `--fail-on-skip` turns any
skip into a failed session (CI's run with every extra installed).
"""

from __future__ import annotations

import importlib.util
import os
import signal
import sysconfig
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from tests.models.colour_vlm import missing_reason as vlm_missing
from tests.models.llama_server import missing_reason as llm_missing
from tests.viewer.browser import why_unavailable as browser_missing

# A local Ray binds to the machine's network address by default; tests keep all their traffic
# on loopback (Ray reads this when it is first imported, and its processes inherit it).
os.environ.setdefault("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")
# LiteLLM fetches its model cost map from the internet when first imported unless told not
# to; our code tells it (`import_litellm`), but a test that imports LiteLLM itself, first, in
# this process or a subprocess, would reach out (and wait for three failed attempts offline).
os.environ.setdefault("LITELLM_LOCAL_MODEL_COST_MAP", "True")
# Hugging Face's libraries (datasets, TRL, transformers) send telemetry and look for newer
# files on the Hub unless told they are offline: the tests use only local files.
for _name in ("HF_HUB_OFFLINE", "HF_HUB_DISABLE_TELEMETRY", "HF_DATASETS_OFFLINE",
              "TRANSFORMERS_OFFLINE"):
    os.environ.setdefault(_name, "1")

# A shell that starts the tests in the background (`pytest &`, nohup, a CI runner without job
# control) starts them with Ctrl-C (SIGINT) ignored, and an ignored signal stays ignored in
# every process they start: a run a test interrupts would never hear it. Ctrl-C is restored
# to its default, as at a terminal.
if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)


@dataclass(frozen=True)
class Extra:
    """An optional piece some tests need: its marker, and why it is missing here (or None)."""

    marker: str  # registered, with what it means, in pyproject.toml
    missing: Callable[[], str | None]


def module_missing(module: str, install: str) -> Callable[[], str | None]:
    """A check that `module` is importable; the reason names the command that installs it."""
    def missing() -> str | None:
        if importlib.util.find_spec(module) is None:
            return f"{module} is not installed ({install})"
        return None

    return missing


#: LangGraph's dev server as installed beside this Python (not any on PATH: it must import
#: this environment's project).
LANGGRAPH_CLI = Path(sysconfig.get_path("scripts")) / "langgraph"


def langgraph_cli_missing() -> str | None:
    """Why `langgraph dev` cannot be started here (None when it can)."""
    if not LANGGRAPH_CLI.is_file():
        return "langgraph-cli is not installed (pip install 'langgraph-cli[inmem]>=0.4,<0.5')"
    return module_missing("langgraph_sdk", "pip install langgraph-sdk")()


#: The export extra (pyarrow writes the Parquet) and `datasets`, which the tests load it with.
EXPORT_INSTALL = "pip install -e '.[export]' 'datasets>=4'"

EXTRAS = (
    Extra("needs_ray", module_missing("ray", "pip install -e '.[ray]'")),
    Extra("needs_thor", module_missing("ai2thor", "pip install -e '.[thor]'")),
    Extra("needs_env", module_missing("pettingzoo", "pip install -e '.[env]'")),
    Extra("needs_trl", module_missing("trl", "pip install -e '.[env,trl]'")),
    Extra("needs_browser", browser_missing),
    Extra("needs_langgraph_cli", langgraph_cli_missing),
    Extra("needs_inspect", module_missing("inspect_ai", "pip install -e '.[inspect]'")),
    Extra("llm", llm_missing),
    Extra("vlm", vlm_missing),
    Extra("needs_export", lambda: module_missing("pyarrow", EXPORT_INSTALL)()
          or module_missing("datasets", EXPORT_INSTALL)()),
)


# The README's command is a newcomer's first check, under 5 minutes on 2 cores (issue 39): the
# end-to-end tests (each more than about 3 s, together about twice the rest) skip in a bare
# `pytest`, saying how to run them; CI runs them right after, with every extra (.ci/run step 2).
SLOW_REASON = "an end-to-end test marked slow: python -m pytest --slow runs it (CI does)"
RUNS_SLOW = "cocobench_runs_slow"


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption("--fail-on-skip", action="store_true",
                     help="fail the session if any test was skipped (every extra installed)")
    parser.addoption("--slow", action="store_true",
                     help="also run the end-to-end tests marked slow (they skip without it, "
                          "or without -m naming them; CI runs them)")
    parser.addoption("--record-skipped", metavar="FILE", type=Path,
                     help="write the node id of each skipped test to FILE, one a line "
                          "(CI reruns them with every extra installed: pytest @FILE)")


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Skip each test whose extra is missing, with the reason (each extra is checked once),
    and each slow one unless asked for."""
    reasons: dict[str, str | None] = {}
    run_slow = runs_slow(config)
    for item in items:
        if not run_slow and item.get_closest_marker("slow") is not None:
            item.add_marker(pytest.mark.skip(reason=SLOW_REASON))
        for extra in EXTRAS:
            if item.get_closest_marker(extra.marker) is None:
                continue
            if extra.marker not in reasons:
                reasons[extra.marker] = extra.missing()
            if reasons[extra.marker] is not None:
                item.add_marker(pytest.mark.skip(reason=reasons[extra.marker]))
    slow_modules_first(items)


def runs_slow(config: pytest.Config) -> bool:
    """Whether this session runs the slow tests: asked for (`--slow`, `-m` naming them), or
    tests named on the command line (a file, a folder, a test id: what you name runs). The
    README's bare command runs the configured paths. Under xdist the controller decides."""
    if hasattr(config, "workerinput"):
        return config.workerinput[RUNS_SLOW]
    return (config.getoption("slow") or "slow" in (config.getoption("markexpr") or "")
            or config.args_source is pytest.Config.ArgsSource.ARGS)


@pytest.hookimpl(optionalhook=True)
def pytest_configure_node(node: Any) -> None:
    """Tell each xdist worker the controller's `runs_slow` (a worker is given the paths as
    arguments, so it cannot tell a bare command from named tests)."""
    node.workerinput[RUNS_SLOW] = runs_slow(node.config)


def slow_modules_first(items: list[pytest.Item]) -> None:
    """Put the modules holding a `slow` test that runs first, each in its order: the xdist
    workers start the long tests early instead of ending the session on one of them (a
    module is kept whole, so its module-scoped fixtures are still built once)."""
    slow = {item.path for item in items
            if item.get_closest_marker("slow") and not item.get_closest_marker("skip")}
    items.sort(key=lambda item: item.path not in slow)


def pytest_sessionfinish(session: pytest.Session, exitstatus: int) -> None:
    record_skipped(session)
    fail_on_skip(session, exitstatus)


def record_skipped(session: pytest.Session) -> None:
    """Under `--record-skipped FILE`, the ids of the tests that skipped, one a line (written by
    the controller under xdist, which has every worker's reports; an empty file when none)."""
    path = session.config.getoption("record_skipped")
    if path is None or hasattr(session.config, "workerinput"):
        return
    reporter = session.config.pluginmanager.get_plugin("terminalreporter")
    skipped = reporter.stats.get("skipped", []) if reporter else []
    ids = sorted({report.nodeid for report in skipped})
    path.write_text("".join(f"{nodeid}\n" for nodeid in ids), encoding="utf-8")


def fail_on_skip(session: pytest.Session, exitstatus: int) -> None:
    """Under `--fail-on-skip`, a skipped test fails the session (exit 1). Under xdist the
    controller decides: it has every worker's reports (a worker's exit status is ignored)."""
    if not session.config.getoption("fail_on_skip") or hasattr(session.config, "workerinput"):
        return
    reporter = session.config.pluginmanager.get_plugin("terminalreporter")
    skipped = reporter.stats.get("skipped", []) if reporter else []
    if skipped and exitstatus == pytest.ExitCode.OK:
        reporter.write_line(f"--fail-on-skip: {len(skipped)} tests skipped (see -rs)", red=True)
        session.exitstatus = pytest.ExitCode.TESTS_FAILED
