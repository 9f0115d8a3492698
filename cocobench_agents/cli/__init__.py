"""The `cocobench` command. The only part of the project that prints."""

from __future__ import annotations

import importlib
import sys
from pathlib import Path

import click

from cocobench_agents.engine.errors import USER_ERRORS as ENGINE_USER_ERRORS
from cocobench_agents.engine.errors import is_user_error as is_engine_user_error
from cocobench_agents.version import __version__

USAGE_ERROR = 2

# Subcommands load on use: `cocobench list` must not pay for LangGraph or LiteLLM.
COMMANDS = {
    "list": "list_cmd:list_command",
    "validate": "validate_cmd:validate_command",
    "score": "score_cmd:score_command",
    "run": "run_cmd:run_command",
    "generate": "generate_cmd:generate_command",
    "report": "report_cmd:report_command",
    "doctor": "doctor_cmd:doctor_command",
    "prompts": "prompts_cmd:prompts_command",
    "planners": "planners_cmd:planners_command",
    "view": "view_cmd:view_command",
    "export": "export_cmd:export_command",
    "import-inspect": "import_inspect_cmd:import_inspect_command",
    "verify": "verify_cmd:verify_command",
    "submit": "submit_cmd:submit_command",
    "leaderboard": "leaderboard_cmd:leaderboard_command",
}

# What `cocobench --help` lists, so that it imports no subcommand (a command missing here is
# imported for its own help line).
SUMMARIES = {
    "list": "List the instances of a suite, config file or folder.",
    "validate": "Run every instance's oracle through the placement, oracle and metric gates.",
    "score": "Rescore trajectory.json files (ours or the reference's).",
    "run": "Run planners on instances into a resumable run folder.",
    "generate": "Regenerate the built-in suites and print the rejections per gate.",
    "report": "The paper's tables and figures from run folders.",
    "doctor": "Check Python, packages, AI2-THOR prerequisites and API keys.",
    "prompts": "List, export and preview prompt suites (the prompt a model gets).",
    "planners": "List every planner: built in, installed by packages, or your own file.",
    "view": "Browse run folders in a browser (live), or export them as static pages.",
    "export": "Write run folders' decisions as a Hugging Face dataset (Parquet + card).",
    "import-inspect": "Write an Inspect log of the cocobench task as a run folder.",
    "verify": "Replay every episode of runs or bundles in the simulator; recompute metrics.",
    "submit": "Pack a finished run as a submission bundle (manifest, checksums).",
    "leaderboard": "A static leaderboard site of bundles and runs, ranking what verifies.",
}

# Mistakes in what the user asked for: reported in one line, exit code 2, no traceback (the
# engine's, the viewer's, the export's and the Inspect log import's).
USER_ERRORS = {**ENGINE_USER_ERRORS, "cocobench_agents.viewer.errors": "ViewerError",
               "cocobench_agents.export.errors": "ExportError",
               "cocobench_agents.inspect_eval.convert": "InspectLogError",
               "cocobench_agents.verify.errors": "VerifyError"}


class LazyGroup(click.Group):
    """A command group whose subcommands are imported when they are used."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return list(COMMANDS)

    def get_command(self, ctx: click.Context, name: str) -> click.Command | None:
        target = COMMANDS.get(name)
        if target is None:
            return None
        module, attribute = target.split(":")
        return getattr(importlib.import_module(f"{__name__}.{module}"), attribute)

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        rows = []
        for name in self.list_commands(ctx):
            summary = SUMMARIES.get(name)
            if summary is None:
                command = self.get_command(ctx, name)
                summary = command.get_short_help_str(limit=70) if command else ""
            rows.append((name, summary))
        with formatter.section("Commands"):
            formatter.write_dl(rows)


@click.group(cls=LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="cocobench")
def cli() -> None:
    """Benchmark LLM/VLM planners on CoCoBench's multi-agent coordination tasks."""


def is_user_error(exc: BaseException) -> bool:
    """Whether `exc` reports a mistake in the user's input."""
    return is_engine_user_error(exc, USER_ERRORS)


def load_env_file(directory: Path | None = None) -> None:
    """Read API keys from ``.env`` in the working directory (python-dotenv); a variable
    already set in the environment wins."""
    path = (directory or Path.cwd()) / ".env"
    if path.is_file():
        from dotenv import load_dotenv

        load_dotenv(path, override=False)


def main(argv: list[str] | None = None) -> int:
    """Entry point: user mistakes become one-line errors and exit code 2, never tracebacks."""
    load_env_file()
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
    except Exception as exc:
        if not is_user_error(exc):
            raise
        # One line per problem, each prefixed; an indented line (a traceback's frame)
        # continues the problem above it.
        for line in str(exc).splitlines() or [""]:
            click.echo(line if line[:1].isspace() else f"cocobench: error: {line}", err=True)
        return USAGE_ERROR
    return code if isinstance(code, int) else 0


if __name__ == "__main__":
    sys.exit(main())
