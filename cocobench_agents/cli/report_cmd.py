"""`cocobench report`: the paper's tables and plots from one or several run folders."""

from __future__ import annotations

from pathlib import Path

import click


@click.command("report")
@click.argument("runs", nargs=-1, required=True, metavar="RUN [RUN...]")
@click.option("--out", "out", type=click.Path(file_okay=False), default=None,
              help="Report folder (default: RUN/report of the first run).")
@click.option("--resamples", type=click.IntRange(min=1), default=2000, show_default=True,
              help="Bootstrap resamples per confidence interval.")
@click.option("--seed", type=int, default=None,
              help="Bootstrap seed (default: a fixed seed, so reports are reproducible).")
@click.option("--no-plots", is_flag=True, help="Write the tables only.")
@click.option("--arms", is_flag=True,
              help="Report every run as its own arm (models labelled 'MODEL @RUN'), for runs "
                   "whose settings differ (temperature, grammar, max steps, ...).")
@click.option("--baseline", metavar="MODEL", default=None,
              help="Compare every model with this one in compare.md (default: every pair of "
                   "models); with --arms, a row label such as 'MODEL @RUN'.")
@click.option("--plot-condition", metavar="COND", default=None,
              help="Condition the per-condition figures show (default: C0_image, else the "
                   "first condition).")
def report_command(runs: tuple[str, ...], out: str | None, resamples: int, seed: int | None,
                   no_plots: bool, plot_condition: str | None, arms: bool,
                   baseline: str | None) -> None:
    """Write Markdown and CSV tables, PNG plots and an index.md for RUN folders.

    Several runs are reported side by side; a model found in several runs is merged, the
    later run winning on an episode present in both, if the runs' settings agree (else the
    report stops, exit 2: report them apart, or with --arms). Runs still in progress or
    interrupted are reported from their complete result lines.
    """
    # Imported here: numpy and the report code load only when a report is made.
    from cocobench_agents.reports import Bootstrap, NotARunFolder, ReportError, build_report
    from cocobench_agents.reports.build import ReportWriteError
    from cocobench_agents.reports.stats import DEFAULT_SEED

    target = Path(out) if out else Path(runs[0]) / "report"
    boot = Bootstrap(resamples=resamples, seed=DEFAULT_SEED if seed is None else seed)
    try:  # build_report checks every RUN before it writes anything
        summary = build_report(list(runs), target, boot=boot, plots=not no_plots,
                               condition=plot_condition, arms=arms, baseline=baseline)
    except NotARunFolder as exc:
        raise click.BadParameter(str(exc), param_hint="RUN") from None
    except ReportError as exc:
        raise click.UsageError(str(exc)) from None
    except ReportWriteError as exc:  # a read-only or full disk: exit 1
        raise click.ClickException(str(exc)) from None
    for warning in summary.warnings:
        click.echo(f"warning: {warning}", err=True)
    for path in summary.files:
        click.echo(str(path))
    arms = f"{len(summary.arms)} arm(s), " if summary.arms else ""
    click.echo(f"{summary.episodes} episodes, {len(summary.models)} model(s), {arms}"
               f"{len(summary.conditions)} condition(s) -> {target / 'index.md'}", err=True)
    if summary.plot_note and not summary.plots:
        click.echo(f"note: {summary.plot_note}", err=True)
