"""`cocobench verify`: replay every episode of runs or bundles in the embedded simulator."""

from __future__ import annotations

import json
from pathlib import Path

import click

from cocobench_agents.cli.tables import table

#: The exit code of a run that does not verify (2 stays the user's mistake).
NOT_VERIFIED = 1


@click.command("verify")
@click.argument("runs", nargs=-1, required=True, metavar="RUN|BUNDLE [...]")
@click.option("--tasks", "tasks", multiple=True, type=click.Path(exists=True, path_type=Path),
              metavar="PATH", help="Reference task configs (a file or folder, e.g. the "
              "official configs) besides the built-in suites: an instance found there must "
              "carry that config. Repeatable.")
@click.option("--jobs", "-j", type=click.IntRange(min=1), default=None,
              help="Processes replaying episodes (default: the cores available).")
@click.option("--json", "as_json", is_flag=True, help="Print every episode's verdict as JSON.")
def verify_command(runs: tuple[str, ...], tasks: tuple[Path, ...], jobs: int | None,
                   as_json: bool) -> None:
    """Replay every landed call of every episode of RUN folders (or submission bundles)
    through the embedded simulator, compare each step with the recording and recompute every
    metric. Each episode is verified, mismatch (the first differing step and field) or
    unverifiable (why). Exit 0 only if every episode verifies, 1 otherwise."""
    from cocobench_agents.verify import VerifyStopped, reference_configs, verify_source

    reference = reference_configs(tasks)
    outcomes = []
    for run in runs:
        try:
            outcomes.append(verify_source(run, reference=reference, jobs=jobs))
        except VerifyStopped as exc:  # nothing printed: a partial verdict is none
            raise click.ClickException(f"{run}: {exc}") from None
    if as_json:
        click.echo(json.dumps([outcome.as_json() for outcome in outcomes], indent=2))
    else:
        for outcome in outcomes:
            _show(outcome)
    if not all(outcome.ok for outcome in outcomes):
        raise click.exceptions.Exit(NOT_VERIFIED)


def _show(outcome) -> None:
    for problem in outcome.problems:
        click.echo(f"cocobench: error: {problem}", err=True)
    failed = [(key, verdict) for key, verdict in outcome.verdicts
              if verdict.status != "verified"]
    if failed:
        click.echo(table(("episode", "verdict", "step", "field", "detail"),
                         [(key.name(), v.status, v.step, v.field, v.detail)
                          for key, v in failed]))
    counts = outcome.counts
    total = len(outcome.verdicts)
    head = "verified" if outcome.ok else "NOT verified"
    if outcome.labels:
        head += f" (not the reference's settings: {', '.join(outcome.labels)})"
    click.echo(f"{outcome.path}: {head}: {counts['verified']}/{total} episodes verified, "
               f"{counts['mismatch']} mismatch, {counts['unverifiable']} unverifiable "
               f"({outcome.elapsed_s:.1f} s, {outcome.processes} "
               f"process{'es' if outcome.processes != 1 else ''})")
