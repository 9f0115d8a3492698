"""The play page of a run with human seats, served on 127.0.0.1 (`LocalServer`).

Only the player plays. Every request needs the run's random token (`secrets`): the page
reads it from its own address, ``/play?token=TOKEN``, and sends it in the `X-Cocobench-Token`
header with each API call (a header, not a cookie: cookies are shared by every port of
127.0.0.1, and another site cannot set a header on a cross-origin request without a CORS
pre-flight, which this server never grants). Requests naming another `Host` are refused
(`host_guard`). The token lives in this process only: it is printed on stderr, never logged
and never written to the run folder.

Routes:

* ``GET /play?token=…`` — the page (HTML with its script and style inline).
* ``GET /play/api/state[?after=VERSION]`` — what the page shows, as JSON; with `after`, the
  answer waits (long polling, up to `LONG_POLL_S`) until the desk has changed since VERSION.
* ``POST /play/api/answer`` — ``{"decision": ID, "action_id": N, "reason": "…",
  "message": "…"}`` (`action_id` null: DONE, every goal is satisfied): 200 taken (and
  already recorded in the run's answer log); 400 a malformed body; 409 not the decision
  being asked now (answered already, withdrawn); 422 an id not on the menu, or a message
  from a seat that sends none; 503 the answer could not be recorded. A refused answer
  changes nothing.
"""

from __future__ import annotations

import asyncio
import base64
import contextlib
import hashlib
import secrets
from collections.abc import AsyncIterator
from importlib import resources

import jinja2
import pydantic
from aiohttp import web
from markupsafe import Markup

from cocobench_agents.play.desk import NotOnMenu, NotPending, NotRecorded, PlayDesk
from cocobench_agents.prompts.parse import MESSAGE_LIMIT
from cocobench_agents.viewer.local_server import (
    Handler,
    LocalServer,
    host_guard,
    request_number,
    send_security_headers,
)

TOKEN_HEADER = "X-Cocobench-Token"
#: How long a state request with `after` waits for a change before answering anyway.
LONG_POLL_S = 25.0
#: The longest reason a person may send (a reply line, not an essay).
MAX_TEXT = 1000
#: The longest message: what a teammate reads of a model's message too (`MESSAGE_LIMIT`),
#: so that the answer log and the broadcast hold the same text.
MAX_MESSAGE = MESSAGE_LIMIT
#: The largest request body taken.
MAX_BODY = 16 * 1024
PAGE_PATH = "/play"
NO_STORE = {"Cache-Control": "no-store"}
#: What every answer allows: nothing (the page's own answer adds its script and style).
POLICY = "default-src 'none'; base-uri 'none'; form-action 'none'; frame-ancestors 'none'"


class AnswerBody(pydantic.BaseModel):
    """The body of ``POST /play/api/answer``: exact types, no other field."""

    model_config = pydantic.ConfigDict(extra="forbid", strict=True)

    decision: str = pydantic.Field(max_length=500)
    action_id: int | None  # None (JSON null): DONE, every goal is satisfied
    reason: str = pydantic.Field("", max_length=MAX_TEXT)
    message: str = pydantic.Field("", max_length=MAX_MESSAGE)


class Changes:
    """Wakes the state requests waiting for the desk to change; lives on the server's loop
    (the desk's listener hands each change over with `call_soon_threadsafe`)."""

    def __init__(self) -> None:
        self._event = asyncio.Event()

    def fire(self) -> None:
        self._event.set()
        self._event = asyncio.Event()

    async def after(self, desk: PlayDesk, version: int, timeout: float) -> None:
        """Return once `desk` has changed since `version`, or after `timeout` seconds."""
        with contextlib.suppress(asyncio.TimeoutError):
            await asyncio.wait_for(self._until_changed(desk, version), timeout)

    async def _until_changed(self, desk: PlayDesk, version: int) -> None:
        while True:
            event = self._event  # taken before the check: a change after it fires this one
            if desk.version != version:
                return
            await event.wait()


class Page:
    """The play page: one HTML document with its script and style inline, allowed by their
    hashes in the Content-Security-Policy (nothing else runs, nothing is fetched but the
    API, frames are `data:` URLs)."""

    def __init__(self, html: str, script: str, style: str) -> None:
        self.html = html
        self.headers = {
            **NO_STORE, "Referrer-Policy": "no-referrer",
            "Content-Security-Policy": (
                f"{POLICY}; script-src '{_sha256(script)}'; style-src '{_sha256(style)}'; "
                "img-src data:; connect-src 'self'")}

    @classmethod
    def render(cls) -> Page:
        files = resources.files("cocobench_agents.play")
        script = (files / "static" / "play.js").read_text(encoding="utf-8")
        style = (files / "static" / "play.css").read_text(encoding="utf-8")
        env = jinja2.Environment(loader=jinja2.PackageLoader("cocobench_agents.play"),
                                 autoescape=True)
        html = env.get_template("play.html").render(
            script=Markup(script), style=Markup(style), token_header=TOKEN_HEADER)
        return cls(html, script, style)

    def response(self) -> web.Response:
        return web.Response(text=self.html, content_type="text/html", headers=self.headers)


DESK = web.AppKey("desk", PlayDesk)
TOKEN = web.AppKey("token", str)
CHANGES = web.AppKey("changes", Changes)
PAGE = web.AppKey("page", Page)


class PlayServer(LocalServer):
    """The play page of `desk` on 127.0.0.1:`port`, behind a fresh random token."""

    def __init__(self, desk: PlayDesk, port: int) -> None:
        self.token = secrets.token_urlsafe(32)
        super().__init__(play_app(desk, self.token), port)

    @property
    def play_url(self) -> str:
        return f"{self.url.rstrip('/')}{PAGE_PATH}?token={self.token}"


def play_app(desk: PlayDesk, token: str) -> web.Application:
    app = web.Application(middlewares=[host_guard, token_guard], client_max_size=MAX_BODY)
    app[DESK], app[TOKEN] = desk, token
    app[CHANGES], app[PAGE] = Changes(), Page.render()
    send_security_headers(app, POLICY)
    app.cleanup_ctx.append(follow_desk)
    app.router.add_get(PAGE_PATH, page)
    app.router.add_get(f"{PAGE_PATH}/api/state", state)
    app.router.add_post(f"{PAGE_PATH}/api/answer", answer)
    return app


@web.middleware
async def token_guard(request: web.Request, handler: Handler) -> web.StreamResponse:
    """The page takes the token from its query, every other route from the header."""
    given = (request.query.get("token") if request.path == PAGE_PATH
             else request.headers.get(TOKEN_HEADER)) or ""
    # A header of raw bytes arrives as surrogate escapes, which no encoding takes: a token
    # is ASCII, so anything else is simply a wrong one (compare_digest takes ASCII text).
    if not given.isascii() or not secrets.compare_digest(given, request.app[TOKEN]):
        return _error(403, "this run's token is missing or wrong: open the play URL that "
                           "cocobench run printed")
    return await handler(request)


async def page(request: web.Request) -> web.Response:
    return request.app[PAGE].response()


async def state(request: web.Request) -> web.Response:
    desk = request.app[DESK]
    after = request.query.get("after")
    if after is not None:
        version = request_number(after, "after (a state version)")
        await request.app[CHANGES].after(desk, version, LONG_POLL_S)
    return web.json_response(desk.snapshot(), headers=NO_STORE)


async def answer(request: web.Request) -> web.Response:
    try:
        body = AnswerBody.model_validate_json(await request.read())
    except web.HTTPRequestEntityTooLarge:
        return _error(413, f"the body is larger than {MAX_BODY} bytes")
    except pydantic.ValidationError as exc:
        return _error(400, f"malformed answer: {_first_problem(exc)}")
    try:  # recording the answer (an fsync) must not hold up the other requests
        await asyncio.to_thread(request.app[DESK].answer, body.decision, body.action_id,
                                reason=body.reason, message=body.message)
    except NotPending as exc:
        return _error(409, str(exc))
    except NotOnMenu as exc:
        return _error(422, str(exc))
    except NotRecorded as exc:  # the run's folder failed: it hears of it too
        return _error(503, str(exc))
    return web.json_response({"accepted": body.decision}, headers=NO_STORE)


async def follow_desk(app: web.Application) -> AsyncIterator[None]:
    """While the server runs, every change of the desk wakes the waiting state requests."""
    loop = asyncio.get_running_loop()
    changes = app[CHANGES]

    def wake() -> None:  # called on the thread that changed the desk
        with contextlib.suppress(RuntimeError):  # the server's loop closed meanwhile
            loop.call_soon_threadsafe(changes.fire)

    unsubscribe = app[DESK].subscribe(wake)
    yield
    unsubscribe()


def _sha256(text: str) -> str:
    return "sha256-" + base64.b64encode(hashlib.sha256(text.encode()).digest()).decode()


def _first_problem(exc: pydantic.ValidationError) -> str:
    error = exc.errors()[0]
    where = ".".join(str(part) for part in error["loc"])
    return f"{where}: {error['msg']}" if where else error["msg"]


def _error(status: int, message: str) -> web.Response:
    return web.json_response({"error": message}, status=status, headers=NO_STORE)
