"""Options shared by several commands (`run`'s own are the request's: `request_options`)."""

from __future__ import annotations

import click

from benchmark_adapter.sim.backends import BACKENDS
from benchmark_adapter.tasks import TaskConfig
from benchmark_adapter.vocabulary import DEFAULT_BACKEND

process_jobs_option = click.option(
    "--jobs", "-j", type=click.IntRange(min=0), default=1, show_default=True,
    help="Worker processes (0 = one per core).")

backend_option = click.option(
    "--backend", type=click.Choice(sorted(BACKENDS)), default=DEFAULT_BACKEND, show_default=True,
    help="Simulator: the embedded one, or real AI2-THOR (pip install 'cocobench-agents[thor]').")


missing_option = click.option(
    "--missing", type=click.Choice(["skip", "error"]), default="skip", show_default=True,
    help="Tasks an index or subset file (e.g. rep240.json) lists but whose configs are absent: "
         "skip them with a warning, as the reference's eval-set selection does, or stop.")


def load_source(source: str, missing: str) -> list[TaskConfig]:
    """The tasks of one SOURCE; skipped missing tasks are reported on stderr in one line."""
    from cocobench_agents.engine import resolve

    return resolve.load_source(source, missing, lambda message: click.echo(
        f"cocobench: warning: {message}", err=True))
