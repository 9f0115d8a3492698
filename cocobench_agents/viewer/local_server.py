"""An aiohttp application served on 127.0.0.1 from its own thread and event loop, so that
the caller's thread stays free (`cocobench view` waits for Ctrl-C; `cocobench run` runs the
engine's own `asyncio.run` while the play page is served).

Every request must name the bound address in its `Host` header: a page of another site that
a DNS-rebinding attack points at 127.0.0.1 sends its own host name and is refused. Every
answer, those aiohttp makes itself included (`GuardedRunner`), carries a
`Content-Security-Policy`, `X-Content-Type-Options: nosniff` and
`Cross-Origin-Resource-Policy: same-origin` (`send_security_headers`), and every number a
request carries is read by `request_number`.
"""

from __future__ import annotations

import asyncio
import errno
import json
import logging
import re
import threading
from collections.abc import Awaitable, Callable
from concurrent.futures import Future
from http import HTTPStatus

from aiohttp import hdrs, web
from aiohttp.http_exceptions import HttpProcessingError
from aiohttp.web_protocol import RequestHandler
from aiohttp.web_request import BaseRequest

from cocobench_agents.viewer.errors import ViewerError

HOST = "127.0.0.1"
#: How long the server waits, when it stops, for requests still being answered.
SHUTDOWN_TIMEOUT_S = 2.0
#: A number in a request: plain ASCII digits, at most 15 of them (below JavaScript's largest
#: exact integer, so a page can send back any number it was given). Not `str.isdigit`, which
#: takes "²" and "１", nor `int`, which also takes "+1", " 1", "1_0" and 5,000 digits (slowly).
REQUEST_NUMBER = re.compile(r"[0-9]{1,15}")

Handler = Callable[[web.Request], Awaitable[web.StreamResponse]]


class NotMalformedRequests(logging.Filter):
    """Lets through every record but aiohttp's traceback for a request it could not parse
    (a raw non-ASCII byte in the path, say): that request was answered 400, and the
    traceback would only clutter the terminal the server runs in."""

    def filter(self, record: logging.LogRecord) -> bool:
        return not (record.exc_info and isinstance(record.exc_info[1], HttpProcessingError))


#: Where the servers log an error (a failing handler's traceback, not a malformed request).
LOG = logging.getLogger("cocobench_agents.server")
LOG.addFilter(NotMalformedRequests())


def request_number(text: str, name: str) -> int:
    """`text`, a number taken from a request's path or query, as an int; a 400 naming `name`
    when it is anything but plain ASCII decimal digits (at most 15)."""
    if REQUEST_NUMBER.fullmatch(text) is None:
        raise web.HTTPBadRequest(
            text=json.dumps({"error": f"{name} must be a whole number (1 to 15 digits 0-9)"}),
            content_type="application/json")
    return int(text)


#: The headers of every answer but its policy: a file is only ever what its type says, and
#: another site's page may not embed one (an `<img>` probing which frames exist).
SECURITY_HEADERS = {"X-Content-Type-Options": "nosniff",
                    "Cross-Origin-Resource-Policy": "same-origin"}
#: The headers (`SECURITY_HEADERS` and the policy) an application's answers carry, kept for
#: the answers aiohttp makes itself (`GuardedRequestHandler`).
APP_HEADERS = web.AppKey("security_headers", dict[str, str])


def send_security_headers(app: web.Application, policy: str) -> None:
    """Every answer of `app` carries `SECURITY_HEADERS` and the `Content-Security-Policy`
    `policy` unless its handler set one of its own (the play page's, which adds its inline
    script and style by their hash). The 400 that aiohttp answers a request it cannot parse
    never reaches the application: `LocalServer` gives it the same headers."""
    app[APP_HEADERS] = {**SECURITY_HEADERS, "Content-Security-Policy": policy}

    async def add(request: web.Request, response: web.StreamResponse) -> None:
        response.headers.update(SECURITY_HEADERS)
        response.headers.setdefault("Content-Security-Policy", policy)

    app.on_response_prepare.append(add)


class GuardedRequestHandler(RequestHandler):
    """aiohttp's connection handler, but the answer it makes itself, without the application
    (a request it cannot parse: a raw non-ASCII byte in the path, an over-long line, an unknown
    method; a handler's unexpected exception), says only its status, never the request line
    the parser quotes, and carries the application's security headers."""

    headers: dict[str, str]  # set as it is made

    def handle_error(self, request: BaseRequest, status: int = 500,
                     exc: BaseException | None = None,
                     message: str | None = None) -> web.StreamResponse:
        super().handle_error(request, status, exc, message)  # it logs; its answer quotes
        try:
            text = f"{status} {HTTPStatus(status).phrase}"
        except ValueError:  # a status the standard does not name
            text = str(status)
        answer = web.Response(status=status, text=text, headers=self.headers)
        answer.force_close()
        return answer


class GuardedServer(web.Server):
    """An aiohttp `Server` whose connections are `GuardedRequestHandler`s with `headers`."""

    headers: dict[str, str]  # set as it is made

    def __call__(self) -> RequestHandler:
        handler = GuardedRequestHandler(self, loop=self._loop, **self._kwargs)
        handler.headers = self.headers
        return handler


class GuardedRunner(web.AppRunner):
    """An `AppRunner` serving its application through a `GuardedServer`.

    aiohttp offers no public hook for the answers its parser makes: the server that
    `AppRunner` builds (`Application._make_handler`) is given the guarded connection handler
    by its class, the one thing that changes (tests/viewer/test_served.py checks those answers
    on every aiohttp this project installs)."""

    async def _make_server(self) -> web.Server:
        server = await super()._make_server()
        server.__class__ = GuardedServer
        server.headers = self.app.get(APP_HEADERS, SECURITY_HEADERS)
        return server


@web.middleware
async def host_guard(request: web.Request, handler: Handler) -> web.StreamResponse:
    """Refuse a request whose `Host` is not this server's own address (DNS rebinding)."""
    port = request.transport.get_extra_info("sockname")[1] if request.transport else None
    if request.headers.get(hdrs.HOST) not in {f"{HOST}:{port}", f"localhost:{port}"}:
        return web.json_response({"error": "this server answers only to its own address "
                                           f"({HOST}:{port} or localhost:{port})"}, status=403)
    return await handler(request)


class LocalServer:
    """Serves `app` on 127.0.0.1:`port` (0: any free port) from a daemon thread between
    `start()` and `stop()`."""

    def __init__(self, app: web.Application, port: int) -> None:
        self.app = app
        self.requested_port = port
        self.port = 0
        self._thread: threading.Thread | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._stop: asyncio.Event | None = None

    @property
    def url(self) -> str:
        return f"http://{HOST}:{self.port}/"

    def start(self) -> LocalServer:
        """Bind and serve; raise `ViewerError` when the port cannot be had."""
        bound: Future[int] = Future()
        self._thread = threading.Thread(target=self._serve, args=(bound,), daemon=True,
                                        name=f"cocobench-server-{self.requested_port}")
        self._thread.start()
        self.port = bound.result()
        return self

    def stop(self) -> None:
        """Stop listening, let requests in progress finish (briefly), end the thread."""
        if self._loop is None or self._stop is None or self._thread is None:
            return
        self._loop.call_soon_threadsafe(self._stop.set)
        self._thread.join(SHUTDOWN_TIMEOUT_S + 5)
        self._loop = self._stop = self._thread = None

    def __enter__(self) -> LocalServer:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def _serve(self, bound: Future[int]) -> None:
        loop = asyncio.new_event_loop()
        try:
            loop.run_until_complete(self._main(loop, bound))
        except Exception as exc:
            if bound.done():
                raise
            bound.set_exception(exc)  # start() raises it rather than wait forever
        finally:
            loop.close()

    async def _main(self, loop: asyncio.AbstractEventLoop, bound: Future[int]) -> None:
        runner = GuardedRunner(self.app, access_log=None, shutdown_timeout=SHUTDOWN_TIMEOUT_S,
                               logger=LOG)
        await runner.setup()
        try:
            await web.TCPSite(runner, HOST, self.requested_port).start()
        except OSError as exc:
            await runner.cleanup()
            bound.set_exception(_bind_error(self.requested_port, exc))
            return
        self._loop, self._stop = loop, asyncio.Event()
        bound.set_result(runner.addresses[0][1])
        try:
            await self._stop.wait()
        finally:
            await runner.cleanup()


def _bind_error(port: int, exc: OSError) -> ViewerError:
    if exc.errno == errno.EADDRINUSE:
        return ViewerError(f"port {port} on {HOST} is already in use: pass --port with a "
                           "free one (0 picks any)")
    return ViewerError(f"cannot listen on {HOST}:{port}: {exc.strerror or exc}")
