"""`cocobench score`: rescore trajectory files written by us or by the reference."""

from __future__ import annotations

import json

import click

from benchmark_adapter.metrics import TrajectoryError, score_trajectory
from benchmark_adapter.trajectory import load_trajectory
from cocobench_agents.cli.tables import table
from cocobench_agents.runfolder.errors import gist

HEADERS = (
    "task_id",
    "success",
    "progress",
    "legal",
    "construct",
    "status",
    "sample",
    "steps",
    "terminal",
)


@click.command("score")
@click.argument("trajectories", nargs=-1, required=True, type=click.Path(dir_okay=False))
@click.option("--json", "as_json", is_flag=True, help="Print a JSON list of episode records.")
def score_command(trajectories: tuple[str, ...], as_json: bool) -> None:
    """Score TRAJECTORY files (trajectory.json). Files that cannot be scored are reported and
    skipped; the exit code is then 2."""
    records, errors = [], 0
    for path in trajectories:
        try:
            records.append(score_trajectory(load_trajectory(path)))
        # JSONDecodeError, UnicodeDecodeError and TrajectoryError are ValueErrors; JSON nested
        # deeper than Python's recursion limit raises RecursionError while it is read.
        except (OSError, ValueError, RecursionError) as exc:
            errors += 1
            click.echo(f"cocobench: error: {path}: {_describe(exc)}", err=True)
        # The scorer names the fields it checks (TrajectoryError); a field of another type
        # that it reads as it is fails deeper, and is named by what failed.
        except (TypeError, AttributeError, KeyError, IndexError, OverflowError) as exc:
            errors += 1
            click.echo(f"cocobench: error: {path}: not a trajectory the scorer can read (a "
                       f"field of another type: {type(exc).__name__}: {gist(exc)})", err=True)
    if as_json:
        click.echo(json.dumps([r.model_dump(mode="json") for r in records], indent=2))
    elif records:
        click.echo(
            table(
                HEADERS,
                [
                    [
                        r.task_id,
                        r.task_success,
                        r.task_progress,
                        r.legal_plan,
                        r.construct_score,
                        r.construct_status,
                        r.construct_sample,
                        r.num_steps,
                        r.terminal_reason,
                    ]
                    for r in records
                ],
            )
        )
    if errors:
        raise click.exceptions.Exit(2)


def _describe(exc: Exception) -> str:
    if isinstance(exc, TrajectoryError):
        return f"{exc.field}: {exc}" if exc.field not in str(exc) else str(exc)
    if isinstance(exc, json.JSONDecodeError):
        return f"not JSON (line {exc.lineno}, column {exc.colno}: {exc.msg})"
    if isinstance(exc, OSError):
        return exc.strerror or str(exc)
    if isinstance(exc, RecursionError):
        return "JSON nested too deeply to read"
    if isinstance(exc, UnicodeDecodeError):
        return f"not UTF-8 text (byte 0x{exc.object[exc.start]:02x} at offset {exc.start})"
    return str(exc)
