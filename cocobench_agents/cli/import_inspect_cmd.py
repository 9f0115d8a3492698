"""`cocobench import-inspect`: an Inspect log of the `cocobench` task as a run folder."""

from __future__ import annotations

import click


@click.command("import-inspect")
@click.argument("log", type=click.Path(dir_okay=False))
@click.option("--out", required=True, type=click.Path(file_okay=False),
              help="The run folder to write (new).")
def import_inspect_command(log: str, out: str) -> None:
    """Write the run folder of LOG, an Inspect log of `inspect eval cocobench_agents/cocobench`
    (needs the inspect extra): `cocobench view OUT` then shows its episodes."""
    try:
        from cocobench_agents.inspect_eval.convert import import_log
    except ModuleNotFoundError as missing:
        if missing.name is None or missing.name.split(".")[0] != "inspect_ai":
            raise  # our own code is broken: not a missing extra
        raise click.UsageError("reading Inspect logs needs inspect_ai: pip install "
                               "'cocobench-agents[inspect]'") from None
    from cocobench_agents.runfolder.errors import RunFolderWriteError

    try:
        imported = import_log(log, out)
    except RunFolderWriteError as exc:  # a full disk: exit 1, the folder taken back
        raise click.ClickException(str(exc)) from None
    errors = f", {imported.errors} infrastructure errors" if imported.errors else ""
    click.echo(f"{imported.folder}: {imported.episodes} episodes{errors}; "
               f"view them with: cocobench view {imported.folder}")
    if imported.incomplete or imported.errors:
        state = (f"incomplete (the log's status: {imported.status})" if imported.incomplete
                 else "errors")
        click.echo(f"warning: the eval is {state}; complete or retry it with: "
                   f"{imported.retry}", err=True)
