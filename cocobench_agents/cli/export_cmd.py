"""`cocobench export`: the decisions of run folders as a Hugging Face dataset (Parquet)."""

from __future__ import annotations

from pathlib import Path

import click


@click.command("export")
@click.argument("runs", nargs=-1, required=True, metavar="RUN [RUN...]")
@click.option("--out", "out", type=click.Path(path_type=Path), required=True, metavar="DIR",
              help="The dataset folder to write (new or empty).")
@click.option("--where", "where", multiple=True, metavar="SELECTOR",
              help="Keep the episodes that pass it: success, failure, legal, illegal, or "
                   "FIELD=VALUE[,VALUE...] with FIELD one of condition, model, arm, task_id, "
                   "cell, dim, family. Repeatable (every one must pass).")
@click.option("--include-infra", is_flag=True,
              help="Also export infrastructure-failure episodes (left out by default).")
def export_command(runs: tuple[str, ...], out: Path, where: tuple[str, ...],
                   include_infra: bool) -> None:
    """Write the model decisions of finished RUN folders as Parquet that Hugging Face
    `datasets` loads as it is (DIR/data/*.parquet), one row per decision, with a dataset
    card (DIR/README.md) naming the runs, models and settings that produced it."""
    # Imported here: pyarrow and the export code load only when an export is written.
    from cocobench_agents.export import ExportWriteError, export_runs

    try:
        summary = export_runs(list(runs), out, where=where, include_infra=include_infra)
    except ExportWriteError as exc:
        raise click.ClickException(str(exc)) from None
    for warning in summary.warnings:
        click.echo(f"warning: {warning}", err=True)
    click.echo(str(summary.data_file))
    click.echo(str(summary.card_file))
    click.echo(f"{summary.rows} decisions of {summary.episodes} episodes, {summary.images} "
               f"with a frame -> {out}", err=True)
