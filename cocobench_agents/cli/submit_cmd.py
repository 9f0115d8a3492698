"""`cocobench submit`: pack a finished run as a submission bundle."""

from __future__ import annotations

from pathlib import Path

import click


@click.group("submit")
def submit_command() -> None:
    """Submission bundles: a run packed with a manifest, for `cocobench verify` and
    `cocobench leaderboard`."""


@submit_command.command("pack")
@click.argument("run", type=click.Path(path_type=Path))
@click.option("--out", "out", type=click.Path(path_type=Path), required=True,
              metavar="NAME.cocobench.tar.gz", help="The bundle to write (new).")
def pack_command(run: Path, out: Path) -> None:
    """Write the finished RUN folder as a bundle: run.json, the result lines, every
    trajectory and kept prompts, and a manifest (the sha256 of every file, package and
    prompt-suite versions, the instance list and its hash, the settings that change what is
    sent or scored)."""
    from cocobench_agents.verify import BundleWriteError, pack

    try:
        manifest = pack(run, out)
    except BundleWriteError as exc:  # a full or read-only disk: exit 1
        raise click.ClickException(str(exc)) from None
    labels = manifest["non_reference"]
    click.echo(str(out))
    note = (f"; not the reference's settings: {', '.join(sorted(labels))}" if labels else "")
    click.echo(f"{len(manifest['files'])} files, {len(manifest['suite']['instances'])} "
               f"instances, conditions {', '.join(manifest['conditions'])}{note}", err=True)
