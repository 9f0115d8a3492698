"""`cocobench generate`: regenerate the built-in suites, or check the shipped copies."""

from __future__ import annotations

import time
from pathlib import Path

import click

from benchmark_adapter.generator import (
    GATES,
    SUITES,
    compare_suite,
    generate,
    package_data_root,
    rejection_table,
    suite_configs,
    suite_files,
    write_suite,
)
from benchmark_adapter.sim.backends import check_backend
from cocobench_agents.cli.options import backend_option, process_jobs_option
from cocobench_agents.cli.tables import table

HEADERS = ("task_type", "cell", "candidates", "kept", *GATES)
SHOWN_PROBLEMS = 20


@click.command("generate")
@click.option(
    "--suite",
    type=click.Choice([*SUITES, "all"]),
    default="all",
    show_default=True,
    help="Which suite to write or check.",
)
@click.option(
    "--out",
    type=click.Path(file_okay=False, path_type=Path),
    default=None,
    help="Folder to write the suite folders into (default: the package data folder).",
)
@process_jobs_option
@click.option(
    "--check",
    is_flag=True,
    help="Write nothing; verify the suites in the package data folder (or --out) are "
    "reproduced byte for byte. Exit 1 if not.",
)
@backend_option
def generate_command(suite: str, out: Path | None, jobs: int, check: bool, backend: str) -> None:
    """Generate the built-in suites from templates and scenes, keeping only candidates that
    pass the placement, oracle and metric gates, and print the rejections per task type."""
    check_backend(backend)
    start = time.perf_counter()
    results = generate(jobs=jobs, backend=backend)
    elapsed = time.perf_counter() - start
    rows = rejection_table(results)
    click.echo(table(HEADERS, [[r[h] for h in HEADERS] for r in rows]))
    totals = {h: sum(r[h] for r in rows) for h in ("candidates", "kept", *GATES)}
    rejected = ", ".join(f"{totals[g]} {g}" for g in GATES)
    click.echo(
        f"{totals['kept']} kept of {totals['candidates']} candidates "
        f"(rejected: {rejected}) in {elapsed:.1f} s"
    )
    suites = suite_configs(results)
    root = out or package_data_root()
    names = SUITES if suite == "all" else (suite,)
    if check:
        _check(root, names, suites)
    else:
        for name in names:
            folder = write_suite(root, name, suite_files(name, suites))
            click.echo(f"wrote {len(suites[name])} instances to {folder}")


def _check(root: Path, names: tuple[str, ...], suites: dict) -> None:
    expected = {name: suite_files(name, suites) for name in names}
    problems = [p for name, files in expected.items() for p in compare_suite(root, name, files)]
    if problems:
        for problem in problems[:SHOWN_PROBLEMS]:
            click.echo(problem)
        if len(problems) > SHOWN_PROBLEMS:
            click.echo(f"… and {len(problems) - SHOWN_PROBLEMS} more")
        click.echo(f"{len(problems)} file(s) under {root} are not reproduced byte for byte")
        raise click.exceptions.Exit(1)
    count = sum(len(files) for files in expected.values())
    click.echo(f"{count} files under {root} reproduced byte for byte")
