"""The live viewer: an aiohttp application on 127.0.0.1 (`LocalServer`). Every page request
first reads what the runs appended since the last one (`Catalog.refresh`)."""

from __future__ import annotations

import mimetypes
from importlib import resources

from aiohttp import web

from cocobench_agents.harness.store import RunFolderError
from cocobench_agents.viewer.local_server import LocalServer, host_guard
from cocobench_agents.viewer.pages import Pages

STATIC = resources.files("cocobench_agents.viewer") / "static"
PAGES = web.AppKey("pages", Pages)
#: Every answer is read fresh: a live page must never be served from the browser's cache.
NO_STORE = {"Cache-Control": "no-store"}


class ViewerServer(LocalServer):
    """The viewer of `pages` on 127.0.0.1:`port`."""

    def __init__(self, pages: Pages, port: int) -> None:
        super().__init__(viewer_app(pages), port)


def viewer_app(pages: Pages) -> web.Application:
    """The viewer's routes. The handlers run on the server's single loop, one at a time,
    which is what the shared catalog needs."""
    app = web.Application(middlewares=[host_guard])
    app[PAGES] = pages
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
    since = request.query.get("since", "0")
    return web.json_response(pages.new_rows(int(since) if since.isdigit() else 0),
                             headers=NO_STORE)


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
        return pages.compare(path.removeprefix("compare/").removesuffix(".html"))
    episode = pages.catalog.find(path)
    return pages.episode(episode) if episode else None


async def static(request: web.Request) -> web.Response:
    name = request.match_info["name"]
    resource = STATIC / name
    if not resource.is_file():
        return _not_found()
    return web.Response(body=resource.read_bytes(), content_type=_mime(name), headers=NO_STORE)


async def run_file(request: web.Request) -> web.Response:
    """A file a trajectory names (a saved frame), read only from inside its run."""
    runs = request.app[PAGES].catalog.runs
    relative = request.match_info["relative"]
    try:
        data = runs[int(request.match_info["run"])].folder.inside(relative).read_bytes()
    except (ValueError, IndexError, OSError, RunFolderError):
        return _not_found()
    return web.Response(body=data, content_type=_mime(relative), headers=NO_STORE)


def _not_found() -> web.Response:
    return web.Response(text="not found", status=404, headers=NO_STORE)


def _mime(name: str) -> str:
    return mimetypes.guess_type(name)[0] or "application/octet-stream"
