"""Keep API keys out of everything we write: messages, errors, records and cache files."""

from __future__ import annotations

import base64
import os
import re
from collections.abc import Iterable, Mapping
from urllib.parse import quote, unquote, urlsplit, urlunsplit

#: Environment variables whose names end like this hold secrets.
SECRET_SUFFIXES = ("_API_KEY", "_TOKEN", "_SECRET")
#: What a secret is replaced with.
REDACTED = "[REDACTED]"
#: Mapping keys whose values are secrets wherever they appear (``--extra`` JSON, headers).
SECRET_KEY = re.compile(r"api[_-]?key|token|secret|password|passwd|authorization|credential|"
                        r"cookie", re.IGNORECASE)
# Values this short are too likely to occur by chance ("1", "true") to be scrubbed safely.
_MIN_SECRET_LEN = 6


def is_secret_name(name: str) -> bool:
    """Whether an environment variable of this name holds a secret."""
    return name.upper().endswith(SECRET_SUFFIXES)


def secret_values(
    extra: Iterable[str | None] = (), environ: Mapping[str, str] | None = None
) -> list[str]:
    """The secret values to scrub: every secret-named environment variable plus `extra`,
    longest first (so a secret that contains another is replaced whole)."""
    env = os.environ if environ is None else environ
    values = {v for k, v in env.items() if is_secret_name(k) and v}
    values.update(v for v in extra if v)
    return sorted((v for v in values if len(v) >= _MIN_SECRET_LEN), key=len, reverse=True)


def redact(text: str, extra: Iterable[str | None] = ()) -> str:
    """`text` with every secret value (see `secret_values`) replaced by `REDACTED`."""
    if not text:
        return text
    return _scrub(text, secret_values(extra))


def redact_obj(obj: object, extra: Iterable[str | None] = ()) -> object:
    """A copy of a JSON-like value (dicts, lists, strings, scalars) with secrets redacted
    in every string, keys included."""
    return _scrub_obj(obj, secret_values(extra))


def _scrub(text: str, values: list[str]) -> str:
    for value in values:
        if value in text:
            text = text.replace(value, REDACTED)
    return text


def _scrub_obj(obj: object, values: list[str]) -> object:
    if isinstance(obj, str):
        return _scrub(obj, values)
    if isinstance(obj, Mapping):
        return {_scrub_obj(k, values): _scrub_obj(v, values) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_scrub_obj(v, values) for v in obj]
    return obj


def named_secrets(obj: object) -> list[str]:
    """The string values held under secret-looking keys anywhere in a JSON-like value."""
    found: list[str] = []
    if isinstance(obj, Mapping):
        for key, value in obj.items():
            if isinstance(key, str) and SECRET_KEY.search(key) and isinstance(value, str):
                found.append(value)
            else:
                found.extend(named_secrets(value))
    elif isinstance(obj, (list, tuple)):
        for value in obj:
            found.extend(named_secrets(value))
    return found


def secret_forms(value: str) -> list[str]:
    """`value` and the forms it travels in: percent-encoded (in a URL or a query) and, for an
    authorization value (``Basic TOKEN``, ``Bearer TOKEN``), the token alone."""
    forms = [value, quote(value, safe="")]
    scheme, _, credential = value.partition(" ")
    if credential.strip() and scheme.isalpha():
        forms.append(credential.strip())
    return list(dict.fromkeys(forms))


def basic_token(user: str, password: str) -> str:
    """The HTTP Basic authorization token of `user` and `password` (RFC 7617)."""
    return base64.b64encode(f"{user}:{password}".encode()).decode("ascii")


def url_parts(url: str | None) -> tuple[str, str] | None:
    """The ``user`` and ``password`` of a URL, percent-decoded (None when it has none, or
    when its credentials are already redacted)."""
    if not url or "@" not in url or REDACTED in url:
        return None
    parts = urlsplit(url)
    if not (parts.username or parts.password):
        return None
    return unquote(parts.username or ""), unquote(parts.password or "")


def url_credentials(url: str | None) -> list[str]:
    """Every form the ``user:password`` of a URL may be seen in: each part as written in the
    URL and percent-decoded, ``user:password``, and the HTTP Basic token they are sent as
    (base64, standard and URL-safe, with and without its padding, percent-encoded): a
    server or proxy that echoes the Authorization header shows the token, not the password.
    None for a URL without credentials."""
    given = url_parts(url)
    if given is None:
        return []
    parts = urlsplit(url)
    user, password = given
    pair = f"{user}:{password}".encode()
    token = basic_token(user, password)
    plain = [v for v in (parts.username, parts.password, user, password) if v]
    tokens = [f"{user}:{password}", token, token.rstrip("="), quote(token, safe=""),
              base64.urlsafe_b64encode(pair).decode("ascii")]
    return list(dict.fromkeys([*(f for v in plain for f in secret_forms(v)), *tokens]))


def redact_url(url: str | None) -> str | None:
    """`url` with its ``user:password@`` part replaced by `REDACTED`."""
    if not url_credentials(url):
        return url
    parts = urlsplit(url)
    host = parts.netloc.rpartition("@")[2]
    return urlunsplit(parts._replace(netloc=f"{REDACTED}@{host}"))


def redact_named(obj: object) -> object:
    """A copy of a JSON-like value whose secret-looking keys have their values redacted."""
    if isinstance(obj, Mapping):
        return {k: REDACTED if isinstance(k, str) and SECRET_KEY.search(k) and v else
                redact_named(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [redact_named(v) for v in obj]
    return obj
