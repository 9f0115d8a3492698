"""The live viewer: the standard library's threading HTTP server on 127.0.0.1. Every
request first reads what the runs appended since the last one (`Catalog.refresh`)."""

from __future__ import annotations

import errno
import json
import mimetypes
import threading
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib import resources
from urllib.parse import parse_qs, unquote, urlsplit

from cocobench_agents.harness.store import RunFolderError
from cocobench_agents.viewer.errors import ViewerError
from cocobench_agents.viewer.pages import Pages

HOST = "127.0.0.1"
STATIC = resources.files("cocobench_agents.viewer") / "static"


class ViewerServer(ThreadingHTTPServer):
    daemon_threads = True

    def __init__(self, pages: Pages, port: int) -> None:
        self.pages = pages
        self.render_lock = threading.Lock()  # one page at a time: the catalog is shared
        try:
            super().__init__((HOST, port), Handler)
        except OSError as exc:
            if exc.errno == errno.EADDRINUSE:
                raise ViewerError(f"port {port} on {HOST} is already in use: pass --port "
                                  "with a free one (0 picks any)") from None
            raise ViewerError(f"cannot listen on {HOST}:{port}: {exc.strerror or exc}") from None

    @property
    def url(self) -> str:
        return f"http://{HOST}:{self.server_address[1]}/"


class Handler(BaseHTTPRequestHandler):
    server: ViewerServer

    def do_GET(self) -> None:
        parts = urlsplit(self.path)
        path = unquote(parts.path).lstrip("/") or "index.html"
        if path.startswith("static/"):
            return self._static(path.removeprefix("static/"))
        if path.startswith("files/"):
            return self._file(path.removeprefix("files/"))
        pages = self.server.pages
        with self.server.render_lock:
            pages.catalog.refresh()
            if path == "api/rows":
                since = parse_qs(parts.query).get("since", ["0"])[0]
                body = json.dumps(pages.new_rows(int(since) if since.isdigit() else 0))
                return self._send(body.encode(), "application/json")
            html = self._page(path)
        if html is None:
            return self._send(b"not found", "text/plain", HTTPStatus.NOT_FOUND)
        self._send(html.encode(), "text/html; charset=utf-8")

    def _page(self, path: str) -> str | None:
        pages = self.server.pages
        if path == "index.html":
            return pages.runs()
        if path.startswith("compare/") and path.endswith(".html"):
            return pages.compare(path.removeprefix("compare/").removesuffix(".html"))
        episode = pages.catalog.find(path)
        return pages.episode(episode) if episode else None

    def _static(self, name: str) -> None:
        resource = STATIC / name
        if "/" in name or not resource.is_file():
            return self._send(b"not found", "text/plain", HTTPStatus.NOT_FOUND)
        self._send(resource.read_bytes(), _mime(name))

    def _file(self, rest: str) -> None:
        """A file a trajectory names (a saved frame), read only from inside its run."""
        index, _, relative = rest.partition("/")
        runs = self.server.pages.catalog.runs
        try:
            target = runs[int(index)].folder.inside(relative)
            data = target.read_bytes()
        except (ValueError, IndexError, OSError, RunFolderError):
            return self._send(b"not found", "text/plain", HTTPStatus.NOT_FOUND)
        self._send(data, _mime(relative))

    def _send(self, body: bytes, content_type: str,
              status: HTTPStatus = HTTPStatus.OK) -> None:
        self.send_response(status)
        self.send_header("Content-Type", content_type)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Cache-Control", "no-store")
        self.end_headers()
        self.wfile.write(body)

    def log_message(self, format: str, *args: object) -> None:
        """Quiet: a page load is not worth a line on the terminal."""


def _mime(name: str) -> str:
    return mimetypes.guess_type(name)[0] or "application/octet-stream"
