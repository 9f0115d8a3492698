"""`cocobench run`: flags, ``COCOBENCH_RUN_*`` variables and a config file → a `RunRequest`
→ the engine, drawn with rich progress → an exit code (DESIGN §4).

Nothing here decides anything about a run: the settings, their defaults and help text, and
whether a resume may change them, are the request's (`engine/request.py`).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click
from click.core import ParameterSource

from cocobench_agents.cli.play_page import play_page
from cocobench_agents.cli.progress import RunView
from cocobench_agents.cli.request_options import ENV_PREFIX, request_options
from cocobench_agents.cli.tables import table
from cocobench_agents.engine.config import ConfigError, command_request
from cocobench_agents.engine.errors import RunInterrupted, RunStopped
from cocobench_agents.engine.request import RunRequest, nest
from cocobench_agents.harness.runaway import runaway_causes
from cocobench_agents.runfolder.infra import retry_command

if TYPE_CHECKING:
    from cocobench_agents.engine.results import EvalResults


@click.command("run", epilog=(
    "Every setting comes, first found first, from its flag, its COCOBENCH_RUN_<OPTION> "
    "variable (e.g. COCOBENCH_RUN_JOBS=16, COCOBENCH_RUN_MODEL='m1 m2'), the --config file, "
    "and its default; with --resume, from the recorded run before the default. A config "
    "file (YAML or TOML) holds the request's fields nested as in "
    "cocobench_agents.RunRequest: --print-config writes one."))
@request_options
@click.option("--config", "config_file", type=click.Path(dir_okay=False, path_type=Path),
              envvar=f"{ENV_PREFIX}CONFIG", show_envvar=True, metavar="FILE",
              help="A YAML or TOML file of settings (the request's fields, nested), below "
                   "flags and COCOBENCH_RUN_* variables.")
@click.option("--resume", is_flag=True,
              help="Complete the missing episodes of --out (starting the run if it is new).")
@click.option("--retry-errors", is_flag=True,
              help="With --resume: re-run infrastructure failures and backend errors too.")
@click.option("--print-config", is_flag=True,
              help="Print the resolved request as YAML (a config file) and exit.")
@click.option("--dry-run", is_flag=True,
              help="Call no model and write nothing: print, per model × condition × arm, the "
                   "episodes, the most model calls, the first prompts' tokens and a cost "
                   "range, against --max-cost.")
@click.option("--json", "as_json", is_flag=True, help="With --dry-run: one JSON object.")
@click.option("--power-baseline", type=click.Path(file_okay=False, path_type=Path),
              metavar="RUN", default=None,
              help="With --dry-run: take the variances of the power estimate from this earlier "
                   "run folder (default: a conservative prior).")
@click.option("--detect", type=click.FloatRange(0.0, 1.0, min_open=True), metavar="DIFF",
              default=None,
              help="With --dry-run: the SR difference to detect (0.05 = 5 points): print the "
                   "epochs or instances that detect it at 80%% power.")
@click.option("--port", type=click.IntRange(0, 65535), default=0, show_default=True,
              help="With human seats: the play page's port on 127.0.0.1 (0: any free one).")
@click.option("--no-browser", is_flag=True,
              help="With human seats: do not open the play page (its URL is printed).")
def run_command(config_file: Path | None, resume: bool, retry_errors: bool,
                print_config: bool, dry_run: bool, as_json: bool, port: int,
                no_browser: bool, power_baseline: Path | None, detect: float | None,
                **options: Any) -> None:
    """Run planners on CoCoBench instances and record one trajectory and one result per
    episode. Every model × condition × instance × epoch is one episode."""
    if not dry_run and (power_baseline is not None or detect is not None):
        raise click.UsageError("--power-baseline and --detect go with --dry-run")
    request = _request(options, config_file, resume)
    if print_config:
        _print_config(request)
        return
    if dry_run:
        _dry_run(request, as_json, resume, power_baseline, detect)
        return
    from cocobench_agents.engine.results import collect_results
    from cocobench_agents.engine.run import run

    view = RunView()
    with play_page(request, port, open_browser=not no_browser) as page:
        try:
            results = run(request, resume=resume, retry_errors=retry_errors,
                          on_event=page.watching(view) if page else view,
                          desk=page.desk if page else None)
        except RunStopped as stopped:
            view.close()
            _summary(collect_results(stopped.folder), request)
            raise RunEndedEarly(stopped) from None
    view.close()
    _summary(results, request)
    if results.stopped is not None:
        raise SpendLimitReached(results.stopped)
    if results.errors or results.planner_errors:
        raise RunHadErrors(results.folder, results.errors, runaway_causes(results),
                           results.planner_errors)


def _print_config(request: RunRequest) -> None:
    """Print the request as a config file, its secrets redacted as run.json records them
    (`ModelSettings.to_record`: the values of secret-looking ``--extra`` keys, the
    ``user:password@`` of ``--api-base``), and any of them, or the key ``--api-key-env``
    names, found in another field."""
    import yaml

    from cocobench_agents.engine.config import request_as_config
    from cocobench_agents.models.secrets import REDACTED, redact_obj

    settings = request.model_settings
    config = {**request_as_config(request), "model_settings": settings.to_record()}
    text = yaml.safe_dump(redact_obj(config, settings.secrets()), sort_keys=False)
    click.echo(text, nl=False)
    if REDACTED in text:
        click.echo(f"note: secrets are printed as {REDACTED}: give them again to run with "
                   "this config (a key: its variable's name with --api-key-env)", err=True)


def _request(options: dict[str, Any], config_file: Path | None, resume: bool) -> RunRequest:
    """The request: the flags and variables given, over the config file, over the recorded
    run (with --resume), over the defaults."""
    try:
        return command_request(nest(_given(options)), config_file=config_file, resume=resume)
    except ConfigError as exc:
        raise ConfigError(_naming_variables(str(exc))) from None


def _naming_variables(message: str) -> str:
    """`message` with each problem of a setting given by its ``COCOBENCH_RUN_*`` variable
    naming the variable first (``COCOBENCH_RUN_TEMPERATURE (--temperature, …): …``): the
    flag alone would send the user looking for an option they never typed."""
    context = click.get_current_context()
    lines = message.split("\n")
    for param in context.command.params:
        if (context.get_parameter_source(param.name or "") != ParameterSource.ENVIRONMENT
                or not isinstance(param.envvar, str)):
            continue
        for flag in (opt for opt in param.opts if opt.startswith("--")):
            lines = [f"{param.envvar} ({flag}, {line.removeprefix(f'{flag} (')}"
                     if line.startswith(f"{flag} (") else line for line in lines]
    return "\n".join(lines)


def _given(options: dict[str, Any]) -> dict[str, Any]:
    """The settings given by a flag or a ``COCOBENCH_RUN_*`` variable (not left at their
    default), by leaf name."""
    context = click.get_current_context()
    given = {name: value for name, value in options.items()
             if context.get_parameter_source(name) in (ParameterSource.COMMANDLINE,
                                                        ParameterSource.ENVIRONMENT)}
    tasks, suite = given.pop("tasks", ()), given.pop("suite", None)
    if tasks and suite:
        raise click.UsageError("give --task or --suite, not both (several --task for several "
                               "sources)")
    if tasks or suite:
        given["sources"] = list(tasks) or [suite]
    return {name: list(value) if isinstance(value, tuple) else value
            for name, value in given.items()}


def _dry_run(request: RunRequest, as_json: bool, resume: bool, power_baseline: Path | None,
             detect: float | None) -> None:
    from cocobench_agents.cli.dry_run_view import dry_run_table
    from cocobench_agents.engine.dry_run import plan

    estimate = plan(request, resume=resume, power_baseline=power_baseline, detect=detect)
    if as_json:
        click.echo(json.dumps(estimate.to_json()))
    else:
        click.echo(dry_run_table(estimate))


class RunEndedEarly(click.ClickException):
    """Interrupted (exit 130), or stopped by the run folder or the executor (exit 1)."""

    def __init__(self, stopped: RunStopped) -> None:
        super().__init__(str(stopped))
        self.exit_code = 130 if isinstance(stopped, RunInterrupted) else 1


class SpendLimitReached(click.ClickException):
    """The run stopped starting episodes at --max-cost / --max-total-tokens."""

    exit_code = 3


class RunHadErrors(click.ClickException):
    """Episodes ended because of the model's infrastructure (exit 1, and how to retry them)
    or of the planner's own code (exit 1, and that a retry would fail the same way)."""

    exit_code = 1

    def __init__(self, folder: Path, failed: int, runaways: dict[str, int],
                 planner_failed: int = 0) -> None:
        told = []
        if failed:
            stopped = ""
            if runaways:
                causes = ", ".join(f"{count} {cause}" for cause, count in
                                   sorted(runaways.items()))
                stopped = (f"; stopped as runaways: {causes} (raise --episode-memory or "
                           "--stall-timeout if they are healthy)")
            told.append(
                f"{_episodes(failed)} ended on an infrastructure error (model backend error, "
                "timeout, unsupported input, or the harness) and count as failures "
                f"above{stopped}; retry them with: {retry_command(folder)}")
        if planner_failed:
            told.append(
                f"{_episodes(planner_failed)} ended on a planner error (the strategy's own "
                "code: its node, file and line are above and in the trajectory) and count as "
                "failures above; running them again unchanged fails the same way: fix the "
                "strategy, then start a new run in another --out")
        super().__init__("\n".join(told))


def _episodes(count: int) -> str:
    return f"{count} episode{'s' if count != 1 else ''}"


def _summary(results: EvalResults, request: RunRequest) -> None:
    from cocobench_agents.graphs import NO_MODEL
    from cocobench_agents.models.settings import unset_sampling_notice
    from cocobench_agents.runfolder.summary import LEGEND, node_lines, summary_table

    headers, rows = summary_table(results)
    click.echo(table(headers, rows, caption=LEGEND))
    called = [m for m in [*request.models, *request.agent_models.values()] if m != NO_MODEL]
    sampling = unset_sampling_notice(request.model_settings, called)
    if sampling:
        click.echo(f"note: {sampling}")
    for line in node_lines(results):  # a Ray run: where its episodes ran
        click.echo(line)
    click.echo(f"results: {results.results_file}  (cocobench report "
               f"{results.folder} --out DIR for the paper's tables)")
