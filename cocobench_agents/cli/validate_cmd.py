"""`cocobench validate`: run every instance's oracle through the quality gates."""

from __future__ import annotations

import time

import click

from benchmark_adapter.sim.backends import check_backend
from benchmark_adapter.validation import METRIC_GATE, validate_tasks
from cocobench_agents.cli.options import (
    backend_option,
    load_source,
    missing_option,
    process_jobs_option,
)
from cocobench_agents.cli.tables import table

HEADERS = ("task_id", "cell", "agents", "steps", "success", "legal", "construct", "result")


@click.command("validate")
@click.argument("source")
@process_jobs_option
@backend_option
@missing_option
def validate_command(source: str, jobs: int, backend: str, missing: str) -> None:
    """Run the oracle of every instance in SOURCE and check it succeeds with a legal plan and a
    construct score of at least 0.95. Exit 1 if any instance fails."""
    check_backend(backend)
    configs = load_source(source, missing)
    if not configs:
        raise click.ClickException(f"{source}: no instances to validate")
    start = time.perf_counter()
    rows = list(validate_tasks(configs, jobs=jobs, backend=backend))
    elapsed = time.perf_counter() - start
    click.echo(
        table(
            HEADERS,
            [
                [
                    r.task_id,
                    r.cell,
                    r.agents,
                    r.steps,
                    r.success,
                    r.legal_plan,
                    r.construct_score if r.construct_status == "scored" else r.construct_status,
                    "pass" if r.passed else r.reason,
                ]
                for r in rows
            ],
        )
    )
    passed = sum(r.passed for r in rows)
    click.echo(
        f"{passed}/{len(rows)} passed (oracle success, legal plan, construct score "
        f">= {METRIC_GATE}) in {elapsed:.2f} s"
    )
    if passed < len(rows):
        raise click.exceptions.Exit(1)
