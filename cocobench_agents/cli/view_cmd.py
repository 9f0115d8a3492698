"""`cocobench view`: browse run folders in a browser, live, or export them as static pages."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import click

if TYPE_CHECKING:
    from cocobench_agents.viewer.pages import Pages


@click.command("view")
@click.argument("runs", nargs=-1, required=True, type=click.Path(path_type=Path))
@click.option("--port", type=click.IntRange(0, 65535), default=8765, show_default=True,
              help="Port on 127.0.0.1 (0: any free one).")
@click.option("--no-browser", is_flag=True, help="Do not open a browser tab.")
@click.option("--export", "export_dir", type=click.Path(path_type=Path), default=None,
              metavar="DIR", help="Write the pages as a static folder instead of serving.")
def view_command(runs: tuple[Path, ...], port: int, no_browser: bool,
                 export_dir: Path | None) -> None:
    """Browse RUN folders in a browser: every episode, each episode's timeline, who did
    what round by round, the construct's signal over time, and instances compared side by
    side. Served on 127.0.0.1 and live: episodes appear as a running run records them."""
    # Imported here: `cocobench view --help` stays fast.
    from cocobench_agents.viewer.pages import Pages
    from cocobench_agents.viewer.source import Catalog

    catalog = Catalog(list(runs))
    for run in catalog.runs:
        if run.junk:
            click.echo(f"cocobench view: {run.path}: skipped {run.junk} invalid result "
                       f"line(s)", err=True)
    if export_dir is not None:
        from cocobench_agents.viewer.export import export

        pages = Pages.create(catalog, live=False)
        count = export(pages, export_dir)
        if pages.unshown:
            first = next(iter(pages.unshown.values()))
            click.echo(f"cocobench view: {len(pages.unshown)} episode(s) exported with their "
                       f"result line only, their trajectory cannot be shown (first: {first})",
                       err=True)
        click.echo(f"wrote {count} pages ({len(catalog.episodes())} episodes) to "
                   f"{export_dir}; open {export_dir / 'index.html'} or serve the folder")
        return
    _serve(Pages.create(catalog, live=True), port, open_browser=not no_browser)


def _serve(pages: Pages, port: int, *, open_browser: bool) -> None:
    import threading

    from cocobench_agents.viewer.server import ViewerServer

    with ViewerServer(pages, port) as server:
        click.echo(f"cocobench view: serving {len(pages.catalog.runs)} run(s) at {server.url} "
                   "(Ctrl-C to stop)")
        if open_browser:
            import webbrowser

            webbrowser.open(server.url)
        try:
            threading.Event().wait()  # the server has its own thread; wait for Ctrl-C
        except KeyboardInterrupt:
            click.echo("stopped")
