"""`cocobench doctor`, through click's CliRunner."""

from __future__ import annotations

import re

import pytest
from click.testing import CliRunner

from cocobench_agents.cli import doctor_cmd
from cocobench_agents.cli.doctor_cmd import API_KEYS, doctor_command

from .conftest import NO_RENDERER, probe_finds

SECRET = "sk-test-DO-NOT-PRINT-4f9a2c"
LINE = re.compile(r"^(ok|warn|fail)\s+\S")


@pytest.fixture
def env(monkeypatch, tmp_path):
    """No real keys, an empty ~/.ai2thor, one fake key set."""
    for name in API_KEYS:
        monkeypatch.delenv(name, raising=False)
    monkeypatch.delenv("COCOBENCH_THOR_BUILD", raising=False)
    monkeypatch.setenv("HOME", str(tmp_path))
    monkeypatch.setenv("ANTHROPIC_API_KEY", SECRET)
    return monkeypatch


def run() -> tuple[int, str]:
    result = CliRunner().invoke(doctor_command, [], color=False)
    return result.exit_code, result.output


def verdicts(output: str) -> dict[str, str]:
    """Check name → status, from the fixed-width lines."""
    return {
        line[6:23].strip(): line[:4].strip() for line in output.splitlines() if LINE.match(line)
    }


def test_doctor_reports_every_check_and_never_a_key(env):
    code, out = run()
    assert code == 0, out
    assert SECRET not in out
    assert "ANTHROPIC_API_KEY" in out and "OPENAI_API_KEY" in out
    assert re.search(r"set: ANTHROPIC_API_KEY;", out)
    found = verdicts(out)
    for name in ("python", "cocobench-agents", "pydantic", "pillow", "click", "API keys"):
        assert found[name] == "ok", out
    assert found["embedded episode"] == "ok", out
    assert {"ai2thor build", "rendering", "ai2thor", "langgraph", "litellm"} <= set(found)
    assert re.search(r"oracle of \S+: success in \d+ steps", out)


def test_warnings_come_with_a_fix_and_do_not_fail(env):
    env.delenv("ANTHROPIC_API_KEY")
    probe_finds(env, NO_RENDERER)
    code, out = run()
    assert code == 0, out
    lines = out.splitlines()
    for i, line in enumerate(lines):
        if line.startswith("warn"):
            assert lines[i + 1].lstrip().startswith("fix: "), line
    assert "neither Vulkan nor an X display" in out and "Xvfb" in out
    assert "set: none" in out


@pytest.mark.needs_thor  # the build cache check needs ai2thor's commit id
def test_build_cache_found(env, tmp_path):
    from ai2thor._builds import COMMIT_ID

    (tmp_path / ".ai2thor" / "releases" / f"thor-CloudRendering-{COMMIT_ID}").mkdir(parents=True)
    _, out = run()
    assert re.search(r"^ok\s+ai2thor build\s+thor-CloudRendering-", out, re.M), out


def test_missing_optional_packages_warn(env):
    env.setattr(doctor_cmd, "_installed_version", lambda name: None if name != "click" else "8")
    checks = doctor_cmd.check_packages(doctor_cmd._installed_version)
    status = {c.name: c.status for c in checks}
    assert status["ai2thor"] == "warn"  # optional: the thor extra
    assert status["pydantic"] == status["langgraph"] == status["litellm"] == "fail"
    assert status["click"] == "ok"
    ai2thor = next(c for c in checks if c.name == "ai2thor")
    assert "cocobench-agents[thor]" in ai2thor.remedy


def test_old_ai2thor_warns():
    checks = doctor_cmd.check_packages(lambda name: "2.7.4" if name == "ai2thor" else "1.0")
    assert any(c.name == "ai2thor version" and c.status == "warn" for c in checks)


def test_a_broken_embedded_episode_fails_the_doctor(env):
    def explode(config, **kwargs):
        raise RuntimeError("simulator broke")

    env.setattr("benchmark_adapter.oracles.run_oracle", explode)
    code, out = run()
    assert code == 1
    assert re.search(r"^fail\s+embedded episode\s+RuntimeError: simulator broke", out, re.M)
    assert "1 required check(s) failed: embedded episode" in out


def test_core_requirements_are_required():
    checks = doctor_cmd.check_packages(lambda name: None, required=["langgraph"])
    status = {c.name: c.status for c in checks}
    assert status["langgraph"] == "fail" and status["litellm"] == "warn"


def test_core_requirements_are_read_from_the_installed_metadata():
    names = doctor_cmd.core_requirements()
    assert {"pydantic", "pillow", "click"} <= set(names)
    assert "ai2thor" not in names and "pytest" not in names  # extras are optional
    assert doctor_cmd.core_requirements("no-such-distribution") == []
