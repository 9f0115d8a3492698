"""`cocobench planners`: every planner a run can use, and where it comes from."""

from __future__ import annotations

import json
from typing import Any

import click

from cocobench_agents.cli.tables import table
from cocobench_agents.graphs import PlannerError, PlannerSpec
from cocobench_agents.graphs.plugins import (
    LoadedPlanner,
    builtin_planners,
    installed_planners,
    user_planners,
)

HEADERS = ("name", "code", "models", "source", "description")


def planner_record(planner: LoadedPlanner) -> dict[str, Any]:
    """The listing record of one planner (a broken one: its error instead of a spec)."""
    spec = planner.spec
    record: dict[str, Any] = {"name": planner.name, **planner.origin.record()}
    if spec is None:
        return {**record, "error": planner.error}
    return {**record, "code": spec.code, "models": _models(spec.uses_models, spec.decentralized),
            "description": spec.description, "shape": _shape(spec)}


@click.command("planners")
@click.argument("refs", nargs=-1, metavar="[FILE.py:NAME|module:NAME]...")
@click.option("--json", "as_json", is_flag=True, help="Print a JSON list instead of a table.")
@click.option("--check", is_flag=True,
              help="Also run the pre-run check on the planners named (none named: on every "
                   "installed one): it compiles, and one demo episode with the greedy model "
                   "ends with a terminal reason. Ends with a passed / FAILED line; exit 1 if "
                   "any planner fails.")
def planners_command(refs: tuple[str, ...], as_json: bool, check: bool) -> None:
    """List the built-in planners, those installed packages register (entry point group
    `cocobench.planners`) and any given as FILE.py:NAME or module:NAME. A package whose
    planner fails to load is listed as broken, with the reason."""
    named = user_planners(refs)
    planners = [*builtin_planners(), *installed_planners(), *named]
    # The planners named are the ones being written: the installed ones are checked when
    # none is named.
    checked = [p for p in (named if refs else planners) if p.origin.kind != "built-in"]
    failures = _check_each(checked) if check else {}
    records = [planner_record(p) for p in planners]
    if as_json:
        click.echo(json.dumps(records, indent=2))
    else:
        click.echo(table(HEADERS, [_row(r) for r in records]))
        click.echo("Use one with --planner NAME (or FILE.py:NAME), or in --conditions as "
                   "CODE_image / CODE_blind.")
    if check:
        for problem in failures.values():
            click.echo(f"cocobench: check failed: {problem}", err=True)
        # The verdict is the last line; beside JSON on stdout it goes to stderr.
        click.echo(_verdict([p.name for p in checked], failures), err=as_json)
        if failures:
            raise click.exceptions.Exit(1)


def _check_each(planners: list[LoadedPlanner]) -> dict[str, str]:
    """Run the pre-run check on each of `planners`; the ones that fail (a broken package
    included), each with why."""
    from cocobench_agents.harness.planner_check import check_planners

    failures = {}
    for planner in planners:
        if planner.spec is None:
            failures[planner.name] = planner.error or "it does not load"
            continue
        try:
            check_planners([planner.name])
        except PlannerError as exc:
            failures[planner.name] = str(exc)
    return failures


def _verdict(checked: list[str], failures: dict[str, str]) -> str:
    if failures:
        return (f"check FAILED: {len(failures)} of {len(checked)} planner(s) not built in: "
                f"{', '.join(failures)}")
    if not checked:
        return "check passed: no planner outside the built-ins to check (they need none)"
    return (f"check passed: {len(checked)} planner(s) not built in compile and end their "
            f"greedy demo episode: {', '.join(checked)}")


def _row(record: dict[str, Any]) -> list[Any]:
    where = record["kind"] + ": " + record["source"]
    if record.get("distribution"):
        where += f" ({record['distribution']})"
    if "error" in record:
        return [record["name"], None, None, where, f"BROKEN: {record['error']}"]
    return [record["name"], record["code"], record["models"], where, record["description"]]


def _shape(spec: PlannerSpec) -> dict[str, Any] | None:
    """How it asks its models, as its spec declares it (`loop` null: not declared, so the dry
    run assumes its bound); None for a planner that calls no model."""
    if not spec.uses_models:
        return None
    return {"loop": spec.loop, "prompt": spec.prompt_kind, "broadcast": spec.broadcast,
            "calls_per_seat": spec.calls_per_seat}


def _models(uses_models: bool, decentralized: bool) -> str:
    if not uses_models:
        return "none"
    return "one per agent" if decentralized else "one for the team"
