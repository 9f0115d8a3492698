"""`cocobench list`: the instances of a suite, folder, file, index or subset."""

from __future__ import annotations

import json

import click

from benchmark_adapter.vocabulary import DEFAULT_TASKS
from cocobench_agents.cli.options import load_source, missing_option
from cocobench_agents.cli.tables import table

HEADERS = ("task_id", "cell", "family", "dim", "agents", "scene", "room", "budget")


def instance_record(config) -> dict:
    """The listing record of one instance."""
    return {
        "task_id": config.task_id,
        "cell": config.cell,
        "family": config.task_family,
        "dim": config.coordination_dim,
        "agents": config.agent_count,
        "scene": config.scene_id,
        "room": config.provenance.get("room"),
        "task_type": config.provenance.get("template"),
        "budget": config.budget,
    }


@click.command("list")
@click.argument("source", default=DEFAULT_TASKS, required=False)
@click.option("--json", "as_json", is_flag=True, help="Print a JSON list instead of a table.")
@missing_option
def list_command(source: str, as_json: bool, missing: str) -> None:
    """List the instances in SOURCE (a suite name, a config file or folder, an index.json or a
    subset file such as rep240.json; default: the cocobench-240 suite)."""
    records = [instance_record(c) for c in load_source(source, missing)]
    if as_json:
        click.echo(json.dumps(records, indent=2))
        return
    click.echo(table(HEADERS, [[r[h] for h in HEADERS] for r in records]))
    click.echo(f"{len(records)} instances")
