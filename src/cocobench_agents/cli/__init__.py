"""The `cocobench` command. The only part of the project that prints."""

from __future__ import annotations

import sys

import click

from benchmark_adapter.sim.thor.errors import ThorUnavailable
from benchmark_adapter.tasks import TaskConfigError
from cocobench_agents import __version__
from cocobench_agents.cli.doctor_cmd import doctor_command
from cocobench_agents.cli.generate_cmd import generate_command
from cocobench_agents.cli.list_cmd import list_command
from cocobench_agents.cli.report_cmd import report_command
from cocobench_agents.cli.run_cmd import run_command
from cocobench_agents.cli.score_cmd import score_command
from cocobench_agents.cli.validate_cmd import validate_command
from cocobench_agents.graphs import UnknownPlanner
from cocobench_agents.harness import PlanError, RunFolderError
from cocobench_agents.models import ModelConfigError
from cocobench_agents.prompts import PromptSuiteError

USAGE_ERROR = 2
# Mistakes in what the user asked for: reported in one line, exit code 2, no traceback.
USER_ERRORS = (TaskConfigError, ModelConfigError, RunFolderError, PlanError, PromptSuiteError,
               UnknownPlanner, ThorUnavailable)


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="cocobench")
def cli() -> None:
    """Benchmark LLM/VLM planners on CoCoBench's multi-agent coordination tasks."""


cli.add_command(list_command)
cli.add_command(validate_command)
cli.add_command(score_command)
cli.add_command(run_command)
cli.add_command(generate_command)
cli.add_command(report_command)
cli.add_command(doctor_command)


def main(argv: list[str] | None = None) -> int:
    """Entry point: user mistakes become one-line errors and exit code 2, never tracebacks."""
    try:
        code = cli.main(args=argv, prog_name="cocobench", standalone_mode=False)
    except click.exceptions.Exit as exc:
        return int(exc.exit_code)
    except click.Abort:
        click.echo("Aborted.", err=True)
        return 130
    except click.ClickException as exc:
        exc.show()
        return USAGE_ERROR if exc.exit_code == 2 else exc.exit_code
    except USER_ERRORS as exc:
        click.echo(f"cocobench: error: {exc}", err=True)
        return USAGE_ERROR
    return code if isinstance(code, int) else 0


if __name__ == "__main__":
    sys.exit(main())
