"""A scripted OpenAI chat-completions server on 127.0.0.1 for fault-injection tests.

Each POST to ``/v1/chat/completions`` takes the next `Behaviour` from the script (or the
default one): a status, a JSON body, an optional delay. The server records every request
body and header, and the most requests it ever had in flight.
"""

from __future__ import annotations

import json
import threading
import time
from collections import deque
from collections.abc import Iterable
from dataclasses import dataclass, field
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any


@dataclass(frozen=True)
class Behaviour:
    """How the server answers one request."""

    status: int = 200
    body: dict[str, Any] = field(default_factory=dict)
    delay_s: float = 0.0
    headers: tuple[tuple[str, str], ...] = ()
    echo_auth: bool = False  # put the request's Authorization header in an error message
    raw: bytes | None = None  # sent verbatim instead of `body` (a broken server)


def completion_body(
    content: str | None, *, prompt_tokens: int = 11, completion_tokens: int = 7
) -> dict[str, Any]:
    """An OpenAI chat.completion response carrying `content`."""
    return {
        "id": "chatcmpl-fake",
        "object": "chat.completion",
        "created": int(time.time()),
        "model": "fake-model",
        "choices": [
            {
                "index": 0,
                "message": {"role": "assistant", "content": content},
                "finish_reason": "stop",
            }
        ],
        "usage": {
            "prompt_tokens": prompt_tokens,
            "completion_tokens": completion_tokens,
            "total_tokens": prompt_tokens + completion_tokens,
        },
    }


def ok(content: str | None = "REASON: fine\nACTION: 1", *, delay_s: float = 0.0) -> Behaviour:
    """A successful completion."""
    return Behaviour(200, completion_body(content), delay_s)


def error(
    status: int, message: str = "boom", *, code: str | None = None, err_type: str = "server_error"
) -> Behaviour:
    """An OpenAI-style error response."""
    return Behaviour(status, {"error": {"message": message, "type": err_type, "code": code}})


RATE_LIMITED = error(429, "Rate limit reached for requests", code="rate_limit_exceeded")
SERVER_ERROR = error(500, "The server had an error while processing your request")
BAD_REQUEST = error(400, "Invalid value for 'messages'", err_type="invalid_request_error")
CONTEXT_WINDOW = error(
    400,
    "This model's maximum context length is 2048 tokens. However, your messages resulted in "
    "9000 tokens. Please reduce the length of the messages.",
    code="context_length_exceeded",
    err_type="invalid_request_error",
)


class FakeOpenAI:
    """The server; use as a context manager, then `program(...)` each test's behaviours."""

    def __init__(self, default: Behaviour | None = None) -> None:
        self.default = default or ok()
        self._script: deque[Behaviour] = deque()
        self._lock = threading.Lock()
        self._stopping = threading.Event()  # set by `program` and at exit: wakes old handlers
        self._generation = 0  # bumped by `program`: handlers of older tests stop counting
        self.requests: list[dict[str, Any]] = []
        self.headers: list[dict[str, str]] = []
        self.in_flight = 0
        self.max_in_flight = 0
        self._httpd = ThreadingHTTPServer(("127.0.0.1", 0), self._handler_class())
        self._httpd.daemon_threads = True
        self._thread = threading.Thread(target=self._httpd.serve_forever, daemon=True)

    @property
    def base_url(self) -> str:
        """The OpenAI-style base URL (ends in ``/v1``)."""
        host, port = self._httpd.server_address[:2]
        return f"http://{host}:{port}/v1"

    @property
    def count(self) -> int:
        """Chat-completion requests received since the last `program`."""
        with self._lock:
            return len(self.requests)

    def program(self, *behaviours: Behaviour, default: Behaviour | None = None) -> FakeOpenAI:
        """Forget past requests and answer the next ones with `behaviours`, then `default`."""
        with self._lock:
            # Requests a previous test abandoned (timeouts) are released and no longer count.
            self._stopping.set()
            self._stopping = threading.Event()
            self._generation += 1
            self.in_flight = 0
            self._script = deque(behaviours)
            self.requests.clear()
            self.headers.clear()
            self.max_in_flight = 0
            if default is not None:
                self.default = default
        return self

    def __enter__(self) -> FakeOpenAI:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stopping.set()  # wakes handlers sleeping in a delay
        self._httpd.shutdown()
        self._httpd.server_close()
        self._thread.join(timeout=5)

    def _next(self, body: dict[str, Any], headers: dict[str, str]) -> Behaviour:
        with self._lock:
            self.requests.append(body)
            self.headers.append(headers)
            self.in_flight += 1
            self.max_in_flight = max(self.max_in_flight, self.in_flight)
            return self._script.popleft() if self._script else self.default

    def _start(
        self, body: dict[str, Any], headers: dict[str, str]
    ) -> tuple[Behaviour, int, threading.Event]:
        behaviour = self._next(body, headers)
        with self._lock:
            return behaviour, self._generation, self._stopping

    def _done(self, generation: int) -> None:
        with self._lock:
            if generation == self._generation:
                self.in_flight -= 1

    def _handler_class(self) -> type[BaseHTTPRequestHandler]:
        server = self

        class Handler(BaseHTTPRequestHandler):
            def log_message(self, *args: object) -> None:  # keep test output clean
                pass

            def _send(self, status: int, body: dict[str, Any], headers: Iterable = (),
                      raw: bytes | None = None) -> None:
                data = json.dumps(body).encode() if raw is None else raw
                self.send_response(status)
                self.send_header("Content-Type", "application/json")
                self.send_header("Content-Length", str(len(data)))
                for name, value in headers:
                    self.send_header(name, value)
                self.end_headers()
                self.wfile.write(data)

            def do_GET(self) -> None:
                if self.path.rstrip("/").endswith("/models"):
                    self._send(200, {"object": "list", "data": [{"id": "fake-model"}]})
                else:
                    self._send(404, {"error": {"message": "not found"}})

            def do_POST(self) -> None:
                length = int(self.headers.get("Content-Length") or 0)
                body = json.loads(self.rfile.read(length) or b"{}")
                headers = {k.lower(): v for k, v in self.headers.items()}
                behaviour, generation, stopping = server._start(body, headers)
                counted = True
                try:
                    if behaviour.delay_s and stopping.wait(behaviour.delay_s):
                        return
                    payload = behaviour.body
                    if behaviour.echo_auth:
                        auth = self.headers.get("Authorization", "")
                        payload = {"error": {"message": f"Incorrect API key provided: {auth}"}}
                    # No longer in flight once the reply is decided, BEFORE it is sent: a
                    # client that has read it may send its next request at once, possibly
                    # before this thread runs again on a loaded machine.
                    server._done(generation)
                    counted = False
                    self._send(behaviour.status, payload, behaviour.headers, behaviour.raw)
                except (BrokenPipeError, ConnectionResetError):
                    pass  # the client gave up (a timeout test)
                finally:
                    if counted:
                        server._done(generation)

        return Handler
