"""`cocobench run`'s options are the request's fields: every field with a flag has its
option (the same flag, the field's help and default), and every option sets a field or is
one of the command's own."""

from __future__ import annotations

import click

from cocobench_agents.cli.run_cmd import run_command
from cocobench_agents.engine.request import iter_fields
from cocobench_agents.setting_kinds import flag_of

OWN = {"config_file", "resume", "retry_errors", "print_config", "dry_run", "as_json", "help",
       "port", "no_browser", "power_baseline", "detect"}
SOURCES = {"tasks", "suite"}  # both set selection.sources


def options() -> dict[str, click.Option]:
    return {p.name: p for p in run_command.params if isinstance(p, click.Option)}


def test_every_flagged_field_has_its_option():
    by_name = options()
    for path, info in iter_fields():
        flag = flag_of(info)
        if path[-1] == "sources":
            assert set(by_name) >= SOURCES
            continue
        if flag is None:
            continue  # config files only (backoff_s, max_reply_chars, …)
        option = by_name[path[-1]]
        assert flag in option.opts, (path, option.opts)
        assert option.help and option.help.startswith(info.description[:20])
        assert option.envvar == "COCOBENCH_RUN_" + flag.lstrip("-").replace("-", "_").upper()


def test_every_option_sets_a_field_or_is_the_commands_own():
    leaves = {path[-1] for path, _ in iter_fields()}
    assert set(options()) - leaves - OWN - SOURCES == set()


def test_defaults_are_the_requests():
    from cocobench_agents.engine.request import RunRequest

    request = RunRequest(out="x")
    by_name = options()
    assert by_name["jobs"].default == request.execution.jobs
    assert by_name["episode_timeout"].default == request.limits.episode_timeout
    assert tuple(by_name["prompt_suites"].default) == tuple(request.prompt_suites)
    assert by_name["temperature"].default == request.model_settings.temperature
