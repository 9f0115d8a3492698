"""`cocobench run` with human seats: the play page is served beside the run, on 127.0.0.1.
Its port is taken before the run starts (a port in use stops it before anything is
written); its address, with the run's token, is printed on stderr as ``play: URL`` and opened
in a browser once the run has started (a request the engine refuses opens no tab)."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from typing import TYPE_CHECKING

import click

from cocobench_agents.engine import events
from cocobench_agents.engine.request import RunRequest

if TYPE_CHECKING:
    from cocobench_agents.play.desk import PlayDesk
    from cocobench_agents.play.server import PlayServer

#: How long the page stays served after the run, for an open page to learn that it ended.
LINGER_S = 1.0
#: What the page says when the run ended as it should / stopped before its end.
FINISHED = "every planned episode has run"
STOPPED = "it stopped before its end (resume it with cocobench run --out RUN --resume)"


class PlayPage:
    """The served play page of one run: its desk, and what the run's events do to it."""

    def __init__(self, server: PlayServer, desk: PlayDesk, *, open_browser: bool) -> None:
        self.server, self.desk = server, desk
        self.open_browser = open_browser
        self.announced = False

    def watching(self, handler: events.EventHandler) -> events.EventHandler:
        """`handler`, then the desk; the first `RunStarted` announces the page."""
        def both(event: events.Event) -> None:
            handler(event)
            if isinstance(event, events.RunStarted) and not self.announced:
                self._announce()
            self.desk.on_event(event)
        return both

    def _announce(self) -> None:
        self.announced = True
        click.echo(f"play: {self.server.play_url}", err=True)
        if self.open_browser:
            import webbrowser

            webbrowser.open(self.server.play_url)


@contextlib.contextmanager
def play_page(request: RunRequest, port: int, *, open_browser: bool
              ) -> Iterator[PlayPage | None]:
    """The play page of the human seats of `request`, served meanwhile (None, and nothing
    served, when no seat is human)."""
    if not request.has_human_seats:
        yield None
        return
    from cocobench_agents.play.desk import PlayDesk
    from cocobench_agents.play.server import PlayServer

    desk = PlayDesk()
    with PlayServer(desk, port) as server:
        page = PlayPage(server, desk, open_browser=open_browser)
        ended = STOPPED
        try:
            yield page
            ended = FINISHED
        finally:
            desk.finish(ended)
            if page.announced:
                desk.end_shown.wait(LINGER_S)
