"""What an OpenAI-compatible chat server takes as a request's `messages`: the roles and content
parts of the Chat Completions API, checked strictly. The pre-run check of a strategy asks its
offline model through this check (`request_problem`), so a request that a real server would
refuse with HTTP 400 (``unsupported content[].type``, an image that is not one) fails the
check, although the offline models never read the prompt.

A user message's content is text or a list of parts, each ``{"type": "text", "text": …}`` or
``{"type": "image_url", "image_url": {"url": …, "detail": …}}``, the url ``http(s)://…`` or a
``data:image/(png|jpeg|gif|webp);base64,…`` URL whose bytes are that image format. System and
developer messages take text (or text parts), an assistant message text or none.
"""

from __future__ import annotations

import base64
import binascii
import re
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, TypeAdapter, ValidationError, field_validator

from .messages import build_messages
from .protocol import ModelRequest

#: The leading bytes of each image format a data URL may declare.
IMAGE_MAGIC = {"png": (b"\x89PNG\r\n\x1a\n",), "jpeg": (b"\xff\xd8\xff",),
               "gif": (b"GIF87a", b"GIF89a"), "webp": (b"RIFF",)}
_DATA_URL = re.compile(r"data:image/(?P<format>[a-z]+);base64,(?P<data>.*)", re.S)


class _Strict(BaseModel):
    model_config = ConfigDict(strict=True, extra="forbid")


class ImageURL(_Strict):
    url: str
    detail: Literal["auto", "low", "high"] | None = None

    @field_validator("url")
    @classmethod
    def _an_image(cls, url: str) -> str:
        if url.startswith(("http://", "https://")):
            return url
        match = _DATA_URL.fullmatch(url)
        if match is None:
            raise ValueError(f"{url[:40]!r}… is neither an http(s) URL nor a "
                             "data:image/FORMAT;base64 URL")
        kind = match["format"]
        if kind not in IMAGE_MAGIC:
            raise ValueError(f"image/{kind} is not one of "
                             f"{', '.join(f'image/{k}' for k in IMAGE_MAGIC)}")
        try:
            data = base64.b64decode(match["data"], validate=True)
        except (binascii.Error, ValueError):
            raise ValueError("its base64 does not decode") from None
        if not data.startswith(IMAGE_MAGIC[kind]):
            raise ValueError(f"its bytes are not a {kind.upper()} image")
        return url


class TextPart(_Strict):
    type: Literal["text"]
    text: str


class ImagePart(_Strict):
    type: Literal["image_url"]
    image_url: ImageURL


Part = Annotated[TextPart | ImagePart, Field(discriminator="type")]
Parts = Annotated[list[Part], Field(min_length=1)]
TextParts = Annotated[list[TextPart], Field(min_length=1)]


class UserMessage(_Strict):
    role: Literal["user"]
    content: str | Parts
    name: str | None = None


class SystemMessage(_Strict):
    role: Literal["system", "developer"]
    content: str | TextParts
    name: str | None = None


class AssistantMessage(_Strict):
    role: Literal["assistant"]
    content: str | TextParts | None = None
    name: str | None = None


Message = Annotated[UserMessage | SystemMessage | AssistantMessage, Field(discriminator="role")]
MESSAGES = TypeAdapter(Annotated[list[Message], Field(min_length=1)])


def messages_problem(messages: Any) -> str | None:
    """Why a server would refuse `messages`, in a line (the first problem, where it is);
    None when it takes them."""
    try:
        MESSAGES.validate_python(messages)
    except ValidationError as exc:
        # The deepest error says most: of `str | list[part]`, the part's, not "not a string";
        # at one depth, one that is not only about the input's type.
        errors = exc.errors()
        paths = [_path(error["loc"]) for error in errors]
        best = max(range(len(errors)), key=lambda i: (
            len(paths[i]), errors[i]["type"] not in ("string_type", "list_type")))
        where = "messages" + "".join(
            f"[{part}]" if isinstance(part, int) else f".{part}" for part in paths[best])
        return f"{where}: {errors[best]['msg'].removeprefix('Value error, ')}"
    return None


def _path(loc: tuple[Any, ...]) -> list[Any]:
    """An error's location without pydantic's union labels: the tag that follows a list
    index (a message's role, a part's type) and a member's type (`str`, `list[…]`)."""
    path: list[Any] = []
    for index, part in enumerate(loc):
        tag = index > 0 and isinstance(loc[index - 1], int) and isinstance(part, str)
        if not tag and part != "str" and "[" not in str(part):
            path.append(part)
    return path


def request_problem(request: Any) -> str | None:
    """Why a server would refuse the chat request a remote client builds from `request`
    (`build_messages`): a prompt that is not text (or valid content parts), a frame that is
    not PNG bytes, a malformed part; None when it would take it."""
    if not isinstance(request, ModelRequest):
        return f"a {type(request).__name__}, not a ModelRequest"
    for index, image in enumerate(request.images):
        if not isinstance(image, bytes):
            return f"images[{index}] is a {type(image).__name__}, not PNG bytes"
    return messages_problem(build_messages(request))
