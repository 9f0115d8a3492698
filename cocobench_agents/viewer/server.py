"""The live viewer: an aiohttp application on 127.0.0.1 (`LocalServer`). Every page request
first reads what the runs appended since the last one (`Catalog.refresh`).

It serves nothing but its pages, the files of the package's static folder (a table made at
start: a request's name is looked up, never joined onto a path) and the files inside the
runs given (`RunSource.file`); its own scripts and styles are the only ones a page may use
(`POLICY`).
"""

from __future__ import annotations

import mimetypes
from dataclasses import dataclass
from importlib import resources

from aiohttp import web

from cocobench_agents.viewer.local_server import (
    LocalServer,
    host_guard,
    request_number,
    send_security_headers,
)
from cocobench_agents.viewer.pages import Pages

STATIC = resources.files("cocobench_agents.viewer") / "static"
#: A page runs only the viewer's own script and style, shows frames from the runs (or
#: `data:` URIs), fetches only its own rows, and is never framed by another site.
POLICY = ("default-src 'none'; script-src 'self'; style-src 'self'; img-src 'self' data:; "
          "connect-src 'self'; base-uri 'none'; form-action 'none'; frame-ancestors 'none'")
#: Every answer is read fresh: a live page must never be served from the browser's cache.
NO_STORE = {"Cache-Control": "no-store"}


@dataclass(frozen=True)
class StaticFile:
    """One file of the package's static folder, as it is served."""

    body: bytes
    content_type: str


def static_files() -> dict[str, StaticFile]:
    """Every file of the package's static folder, by name, read once."""
    return {r.name: StaticFile(r.read_bytes(), _mime(r.name))
            for r in STATIC.iterdir() if r.is_file()}


PAGES = web.AppKey("pages", Pages)
STATIC_FILES = web.AppKey("static_files", dict[str, StaticFile])


class ViewerServer(LocalServer):
    """The viewer of `pages` on 127.0.0.1:`port`."""

    def __init__(self, pages: Pages, port: int) -> None:
        super().__init__(viewer_app(pages), port)


def viewer_app(pages: Pages) -> web.Application:
    """The viewer's routes. The handlers run on the server's single loop, one at a time,
    which is what the shared catalog needs."""
    app = web.Application(middlewares=[host_guard])
    app[PAGES], app[STATIC_FILES] = pages, static_files()
    send_security_headers(app, POLICY)
    app.router.add_get("/api/rows", rows)
    app.router.add_get("/static/{name}", static)
    app.router.add_get("/files/{run}/{relative:.+}", run_file)
    app.router.add_get("/", page)
    app.router.add_get("/{path:.+}", page)
    return app


async def rows(request: web.Request) -> web.Response:
    """The rows of episodes recorded after `since` (the live runs page polls this)."""
    pages = request.app[PAGES]
    pages.catalog.refresh()
    since = request_number(request.query.get("since", "0"), "since")
    return web.json_response(pages.new_rows(since), headers=NO_STORE)


async def page(request: web.Request) -> web.Response:
    pages = request.app[PAGES]
    pages.catalog.refresh()
    html = _render(pages, request.match_info.get("path") or "index.html")
    if html is None:
        return _not_found()
    return web.Response(text=html, content_type="text/html", headers=NO_STORE)


def _render(pages: Pages, path: str) -> str | None:
    if path == "index.html":
        return pages.runs()
    if path.startswith("compare/") and path.endswith(".html"):
        return pages.compare_page(path)
    episode = pages.catalog.find(path)
    return pages.episode(episode) if episode else None


async def static(request: web.Request) -> web.Response:
    """One of the package's static files, found by its name in the table made at start."""
    found = request.app[STATIC_FILES].get(request.match_info["name"])
    if found is None:
        return _not_found()
    return web.Response(body=found.body, content_type=found.content_type, headers=NO_STORE)


async def run_file(request: web.Request) -> web.Response:
    """A file a trajectory names (a saved frame), read only from inside its run."""
    runs = request.app[PAGES].catalog.runs
    index = request_number(request.match_info["run"], "the run's number")
    relative = request.match_info["relative"]
    path = runs[index].file(relative) if index < len(runs) else None
    if path is None:
        return _not_found()
    try:
        data = path.read_bytes()
    except OSError:  # gone or unreadable since it was found
        return _not_found()
    return web.Response(body=data, content_type=_mime(relative), headers=NO_STORE)


def _not_found() -> web.Response:
    return web.Response(text="not found", status=404, headers=NO_STORE)


def _mime(name: str) -> str:
    return mimetypes.guess_type(name)[0] or "application/octet-stream"
