"""`cocobench doctor`: check this machine and say what to fix.

Each check prints `ok`, `warn` or `fail` and, when something is off, a one-line remedy. Only
what every run needs can fail (Python, the core packages, an embedded episode); what only
some runs need (AI2-THOR, model API keys, optional libraries) warns. API keys are reported as
"set" or "not set", never shown.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from importlib.metadata import PackageNotFoundError, requires, version
from typing import Literal

import click

from benchmark_adapter.vocabulary import DEMO_SUITE

Status = Literal["ok", "warn", "fail"]

MIN_PYTHON = (3, 10)
REQUIRED_PACKAGES = ("cocobench-agents", "pydantic", "pillow", "click")
OPTIONAL_PACKAGES = {
    "ai2thor": "pip install 'cocobench-agents[thor]'   (only for --backend ai2thor)",
    "langgraph": "pip install langgraph   (needed by the LLM planners' graphs)",
    "litellm": "pip install litellm   (needed to call hosted models)",
}
# Environment variables LiteLLM reads for the common providers.
API_KEYS = (
    "OPENAI_API_KEY",
    "ANTHROPIC_API_KEY",
    "GEMINI_API_KEY",
    "GOOGLE_API_KEY",
    "MISTRAL_API_KEY",
    "GROQ_API_KEY",
    "DEEPSEEK_API_KEY",
    "TOGETHERAI_API_KEY",
    "OPENROUTER_API_KEY",
    "XAI_API_KEY",
    "AZURE_API_KEY",
)
DOCS = "docs/ai2thor-backend.md"
OFFLINE_BUILD = (
    "offline? copy a downloaded ~/.ai2thor/releases/thor-<Platform>-<commit>/ here, or set "
    f"COCOBENCH_THOR_BUILD=/path/to/its/executable ({DOCS})"
)
RENDERER = (
    "GPU server: sudo apt-get install libvulkan1 vulkan-tools (CloudRendering); otherwise "
    f"run Xvfb :99 & and export DISPLAY=:99 (Linux64) ({DOCS})"
)


@dataclass(frozen=True)
class Check:
    """One verdict: a status, what was checked, what was found, and how to fix it."""

    status: Status
    name: str
    detail: str
    remedy: str = ""


def check_python() -> Check:
    """The interpreter is new enough."""
    found = ".".join(map(str, sys.version_info[:3]))
    if sys.version_info[:2] >= MIN_PYTHON:
        return Check("ok", "python", found)
    wanted = ".".join(map(str, MIN_PYTHON))
    return Check("fail", "python", found, f"use Python {wanted} or newer")


def check_packages(
    lookup: Callable[[str], str | None] | None = None, required: Sequence[str] | None = None
) -> list[Check]:
    """Versions of the packages every run needs (fail if missing) and of the optional ones
    (warn). Required = the essentials plus cocobench-agents' own core requirements."""
    lookup = lookup or _installed_version
    required = list(dict.fromkeys([*REQUIRED_PACKAGES, *(required or core_requirements())]))
    checks = [
        Check("ok", name, found)
        if (found := lookup(name))
        else Check("fail", name, "not installed", "pip install -e .  (or reinstall the package)")
        for name in required
    ]
    for name, remedy in OPTIONAL_PACKAGES.items():
        if name in required:
            continue
        found = lookup(name)
        checks.append(
            Check("ok", name, found) if found else Check("warn", name, "not installed", remedy)
        )
    return checks + _ai2thor_version_check(lookup("ai2thor"))


def core_requirements(distribution: str = "cocobench-agents") -> list[str]:
    """Names of a distribution's requirements outside any extra that apply here (their
    environment markers hold: ``tomli; python_version < '3.11'`` not on 3.11), as
    installed."""
    from packaging.requirements import Requirement

    try:
        specs = requires(distribution) or []
    except PackageNotFoundError:
        return []
    required = (Requirement(spec) for spec in specs)
    return [req.name.lower() for req in required
            if req.marker is None or req.marker.evaluate({"extra": ""})]


def _ai2thor_version_check(found: str | None) -> list[Check]:
    from benchmark_adapter.sim.thor.loader import SUPPORTED_MAJOR

    if found is None or found.startswith(SUPPORTED_MAJOR):
        return []
    return [
        Check(
            "warn",
            "ai2thor version",
            f"{found}; the ai2thor backend needs 5.x",
            "pip install 'ai2thor>=5.0.0,<6'",
        )
    ]


def check_build_cache() -> Check:
    """Whether the AI2-THOR build this ai2thor release needs is cached (or given)."""
    from benchmark_adapter.sim.thor.environment import (
        build_name,
        cached_builds,
        check_local_executable,
        releases_dir,
    )
    from benchmark_adapter.sim.thor.errors import ThorUnavailable
    from benchmark_adapter.sim.thor.options import PLATFORMS

    local = os.environ.get("COCOBENCH_THOR_BUILD")
    if local:
        try:
            check_local_executable(local)
        except ThorUnavailable as exc:
            return Check("warn", "ai2thor build", exc.problem, exc.remedy)
        return Check("ok", "ai2thor build", f"COCOBENCH_THOR_BUILD={local}")
    commit = _ai2thor_commit()
    if commit is None:
        return Check(
            "warn",
            "ai2thor build",
            "not checked: ai2thor is not installed",
            OPTIONAL_PACKAGES["ai2thor"],
        )
    wanted = {build_name(p, commit) for p in PLATFORMS if p != "auto"}
    cached = [p.name for p in cached_builds()]
    hits = sorted(wanted.intersection(cached))
    if hits:
        return Check("ok", "ai2thor build", f"{', '.join(hits)} in {releases_dir()}")
    others = f" (other builds there: {', '.join(cached[:3])})" if cached else ""
    return Check(
        "warn",
        "ai2thor build",
        f"none for commit {commit[:8]} in {releases_dir()}{others}; the first ai2thor run "
        "downloads several hundred MB",
        OFFLINE_BUILD,
    )


def _ai2thor_commit() -> str | None:
    if _installed_version("ai2thor") is None:
        return None
    try:
        from ai2thor._builds import COMMIT_ID  # a generated constant; imports nothing heavy
    except ImportError:
        return None
    return str(COMMIT_ID)


def check_rendering() -> Check:
    """Which AI2-THOR platform this machine can render with (CloudRendering or Linux64)."""
    from benchmark_adapter.sim.thor.environment import choose_platform, probe
    from benchmark_adapter.sim.thor.errors import ThorUnavailable
    from benchmark_adapter.sim.thor.options import ThorOptions

    try:
        options = ThorOptions.from_env()
    except ValueError as exc:
        return Check("warn", "rendering", str(exc), "fix the COCOBENCH_THOR_* variable")
    found = probe(options.x_display)
    seen = f"Vulkan: {found.vulkan or 'no'}, vulkaninfo: {'yes' if found.vulkaninfo else 'no'}, "
    seen += f"DISPLAY: {found.display or 'unset'}"
    try:
        platform = choose_platform(options, found)
    except ThorUnavailable as exc:
        return Check("warn", "rendering", f"{exc.problem} ({seen})", RENDERER)
    return Check("ok", "rendering", f"AI2-THOR can use {platform} ({seen})")


def check_api_keys(environ: Mapping[str, str] | None = None) -> Check:
    """Which model API keys are set; never their values."""
    environ = os.environ if environ is None else environ
    found = [name for name in API_KEYS if environ.get(name)]
    missing = [name for name in API_KEYS if name not in found]
    detail = f"set: {', '.join(found) or 'none'}; not set: {', '.join(missing) or 'none'}"
    if found:
        return Check("ok", "API keys", detail)
    return Check(
        "warn",
        "API keys",
        detail,
        "export the key of the provider you will benchmark (e.g. OPENAI_API_KEY); the offline "
        "planners need none",
    )


def check_embedded_episode() -> Check:
    """The oracle of one demo instance runs, succeeds with a legal plan, and scores."""
    from benchmark_adapter.metrics import score_trajectory
    from benchmark_adapter.oracles import run_oracle
    from benchmark_adapter.tasks import load_tasks

    try:
        config = load_tasks(DEMO_SUITE)[0]
        start = time.perf_counter()
        result = score_trajectory(run_oracle(config))
        elapsed = time.perf_counter() - start
    except Exception as exc:  # noqa: BLE001 - any failure here is the finding to report
        return Check("fail", "embedded episode", f"{type(exc).__name__}: {exc}", _REINSTALL)
    if not (result.task_success and result.legal_plan):
        return Check(
            "fail",
            "embedded episode",
            f"the oracle of {config.task_id} did not succeed legally",
            _REINSTALL,
        )
    return Check(
        "ok",
        "embedded episode",
        f"oracle of {config.task_id}: success in {result.num_steps} steps, {elapsed:.2f} s",
    )


_REINSTALL = "reinstall (pip install -e .) and, if it persists, report it with this output"


def run_checks() -> list[Check]:
    """Every check, in display order."""
    return [
        check_python(),
        *check_packages(),
        check_build_cache(),
        check_rendering(),
        check_api_keys(),
        check_embedded_episode(),
    ]


def _installed_version(distribution: str) -> str | None:
    try:
        return version(distribution)
    except PackageNotFoundError:
        return None


def render(check: Check) -> str:
    """One check as one line, plus a remedy line when there is something to fix."""
    colour = {"ok": "green", "warn": "yellow", "fail": "red"}[check.status]
    line = f"{click.style(f'{check.status:<4}', fg=colour)}  {check.name:<17} {check.detail}"
    return line + (f"\n      fix: {check.remedy}" if check.remedy and check.status != "ok" else "")


@click.command("doctor")
def doctor_command() -> None:
    """Check Python, packages, AI2-THOR (build cache, Vulkan / X display), model API keys and
    a quick embedded episode, saying what to fix. Exit 1 only if something required fails."""
    checks = run_checks()
    for check in checks:
        click.echo(render(check))
    failed = [c.name for c in checks if c.status == "fail"]
    warned = sum(c.status == "warn" for c in checks)
    if failed:
        click.echo(f"{len(failed)} required check(s) failed: {', '.join(failed)}")
        raise click.exceptions.Exit(1)
    click.echo(f"ready ({warned} warning(s): optional features)" if warned else "all good")
