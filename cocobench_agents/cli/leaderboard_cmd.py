"""`cocobench leaderboard`: a static leaderboard site from bundles and run folders."""

from __future__ import annotations

from pathlib import Path

import click


@click.command("leaderboard")
@click.argument("sources", nargs=-1, required=True, metavar="BUNDLE|RUN [...]")
@click.option("--out", "out", type=click.Path(path_type=Path), required=True, metavar="DIR",
              help="The site folder to write (new or empty).")
@click.option("--tasks", "tasks", multiple=True, type=click.Path(exists=True, path_type=Path),
              metavar="PATH", help="Reference task configs besides the built-in suites (as "
              "cocobench verify --tasks). Repeatable.")
@click.option("--jobs", "-j", type=click.IntRange(min=1), default=None,
              help="Processes replaying episodes (default: the cores available).")
def leaderboard_command(sources: tuple[str, ...], out: Path, tasks: tuple[Path, ...],
                        jobs: int | None) -> None:
    """Verify every BUNDLE or RUN and write a static leaderboard site into DIR: one row per
    model × scaffold × condition with SR, CS and CS_D1–D4 (clustered intervals), pass^k,
    legal plan, tokens and dollars per episode and a verification badge; only verified rows
    of the reference's settings are ranked. Each row links to its episodes' pages."""
    from cocobench_agents.leaderboard import SiteWriteError, build_leaderboard
    from cocobench_agents.verify import VerifyStopped, reference_configs

    try:
        board = build_leaderboard(sources, out, reference=reference_configs(tasks), jobs=jobs)
    except (SiteWriteError, VerifyStopped) as exc:  # a full disk, a killed worker: exit 1
        raise click.ClickException(str(exc)) from None
    for outcome in board.verifications:
        state = "verified" if outcome.ok else "NOT verified (its rows are not ranked)"
        click.echo(f"{outcome.path}: {state}", err=True)
    ranked = sum(row.rank is not None for row in board.rows)
    click.echo(f"{len(board.rows)} rows, {ranked} ranked -> {board.index}", err=True)
    click.echo(str(board.index))
