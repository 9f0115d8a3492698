"""Hostile requests for the servers on 127.0.0.1 (the viewer's and the play page's): raw HTTP
sent byte for byte (no client normalises `..` or re-encodes anything, as `curl --path-as-is`),
generated paths and numbers in every encoding a traversal may hide in, and marker files that
no answer may ever contain."""

from __future__ import annotations

import secrets
import socket
import urllib.parse
from dataclasses import dataclass
from pathlib import Path

from hypothesis import strategies as st

#: What a number in a request may look like besides plain digits: digits to `str.isdigit`
#: (superscripts, other scripts, full width) or to `int` (signs, spaces, underscores) but not
#: plain ASCII decimals, and far too many digits.
ODD_NUMBERS = ["", "²", "%C2%B2", "１", "%EF%BC%91", "٣", "%D9%A3", "-1", "+1", "%2B1", " 1",
               "%201", "1_0", "0x1f", "1e3", "1.0", "%00", "1%00", "9" * 5000, "0" * 16,
               "1" * 16]
#: Every digit to `str.isdigit` but ASCII's: digits of other scripts (which `int` reads) and
#: superscript, circled and other digits (which it does not).
OTHER_DIGITS = [c for c in map(chr, range(0x80, 0x20000)) if c.isdigit()]  # none above it
#: Path pieces a traversal hides in: dots and separators in every encoding (once and twice
#: encoded), NUL, overlong and invalid UTF-8, raw backslashes, and names worth reading.
PIECES = ["..", ".", "%2e%2e", "%2E%2E", ".%2e", "%2e.", "%252e%252e", "%2f", "%2F", "%5c",
          "%5C", "\\", "%252f", "%255c", "%00", "a%00b", "%c0%af", "%c0%ae%c0%ae", "%e0%80%af",
          "%ff", "%c2%b2", "", "/", "//", "etc", "passwd", "__init__.py", "server.py",
          "local_server.py", "run.json", "results.jsonl", "static", "files", "0", "1",
          "index.html", "episode", "compare", "episodes", "play", "api", "state", "marker.txt"]
#: A path separator and a parent folder as a traversal may spell them.
SEPARATORS = ["%2f", "/", "%2F", "%5c", "\\", "%252f", "%c0%af", "%e0%80%af", "%00/"]
PARENTS = ["..", "%2e%2e", ".%2e", "%2e.", "%252e%252e", "%c0%ae%c0%ae", "..%00"]
#: What ends a request target: nothing, or (one time in four) a raw byte that no request
#: target may hold (answered 400 by aiohttp's parser before any route).
TAILS = [b""] * 15 + [b"\xc0\xaf", b"\xff", b"\xc2\xb2", b"\x00", b" "]


@dataclass(frozen=True)
class Answer:
    """A server's answer to `send`."""

    status: int
    raw: bytes  # the whole answer: status line, headers and body

    def header(self, name: str) -> str | None:
        head = self.raw.partition(b"\r\n\r\n")[0].decode("latin-1").split("\r\n")[1:]
        found = [v.strip() for k, _, v in (h.partition(":") for h in head)
                 if k.lower() == name.lower()]
        return found[0] if found else None


def send(port: int, target: bytes | str, *, method: str = "GET", body: bytes | None = None,
         headers: dict[str, str] | None = None) -> Answer:
    """One request to 127.0.0.1:`port` with `target` exactly as given, naming the server's
    own `Host` unless `headers` name another; the whole answer (the connection is closed
    after it)."""
    if isinstance(target, str):
        target = target.encode()
    fields = {"Host": f"127.0.0.1:{port}", "Connection": "close", **(headers or {})}
    if body is not None:
        fields["Content-Length"] = str(len(body))
    lines = [f"{method} ".encode() + target + b" HTTP/1.1",
             *(f"{k}: {v}".encode() for k, v in fields.items())]
    with socket.create_connection(("127.0.0.1", port), timeout=30) as connection:
        connection.sendall(b"\r\n".join(lines) + b"\r\n\r\n" + (body or b""))
        raw = b""
        while chunk := connection.recv(65536):
            raw += chunk
    return Answer(int(raw.split(b" ", 2)[1]), raw)


@dataclass(frozen=True)
class Markers:
    """A secret written to files outside what a server may serve: whoever answers with it
    has served one of them."""

    secret: bytes
    files: tuple[Path, ...]


def plant_markers(*folders: Path) -> Markers:
    """A `marker.txt` holding one fresh secret in each of `folders`."""
    secret = f"MARKER-{secrets.token_hex(16)}".encode()
    files = tuple(folder / "marker.txt" for folder in folders)
    for file in files:
        file.write_bytes(secret)
    return Markers(secret, files)


def encodings(path: Path) -> list[str]:
    """An absolute path as a request may carry it: raw, its slashes encoded once (`%2f`) and
    twice (`%252f`), and as backslashes."""
    text = str(path)
    return [text, text.replace("/", "%2f"), text.replace("/", "%252f"),
            text.replace("/", "%5c"), urllib.parse.quote(text, safe="")]


def numbers() -> st.SearchStrategy[str]:
    """Numbers as requests carry them: odd (`ODD_NUMBERS`), in `OTHER_DIGITS` (percent-
    encoded UTF-8), plain and huge."""
    digits = st.lists(st.sampled_from(OTHER_DIGITS), min_size=1, max_size=3).map("".join)
    return st.one_of(st.sampled_from(ODD_NUMBERS), digits.map(urllib.parse.quote),
                     st.integers(0, 3).map(str), st.integers(0, 10**40).map(str))


def traversals(targets: list[Path]) -> st.SearchStrategy[str]:
    """Ways to name one of `targets` (absolute paths) from anywhere: its absolute path, or
    0-12 parent folders then its path from the root, with separators and parents spelled in
    any of their encodings."""
    def spell(target: Path, separator: str, parent: str, depth: int, absolute: bool) -> str:
        parts = [parent] * depth + list(target.parts[1:])
        return (separator if absolute else "") + separator.join(parts)

    return st.builds(spell, st.sampled_from(targets), st.sampled_from(SEPARATORS),
                     st.sampled_from(PARENTS), st.integers(0, 12), st.booleans())


def targets(route: str, markers: list[Path]) -> st.SearchStrategy[bytes]:
    """Request targets for `route`, with `{n}` (a number: `numbers`) and `{p}` (a path: a
    traversal to one of `markers`, or pieces of `PIECES`, numbers and random percent-encoded
    text) filled in, now and then a query of numbers and text after it, and a `TAILS` byte."""
    piece = st.one_of(st.sampled_from(PIECES), numbers(),
                      st.text(max_size=8).map(lambda t: urllib.parse.quote(t, safe="")))
    path = st.one_of(traversals(markers), st.lists(piece, min_size=1, max_size=4).map("/".join))
    value = st.one_of(numbers(), st.text(max_size=8).map(urllib.parse.quote))
    query = st.lists(st.tuples(st.sampled_from(["since", "after", "token", "run", "x"]), value),
                     max_size=2)

    def fill(number: str, path: str, pairs: list[tuple[str, str]], tail: bytes) -> bytes:
        target = route.replace("{n}", number).replace("{p}", path)
        if pairs:
            target += ("&" if "?" in route else "?") + "&".join(f"{k}={v}" for k, v in pairs)
        return target.encode() + tail

    return st.builds(fill, numbers(), path, query, st.sampled_from(TAILS))
