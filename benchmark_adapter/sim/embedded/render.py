"""Schematic egocentric frames for the embedded (symbolic) household simulator.

There is no 3-D engine, so AI2-THOR-style metadata is projected onto a pinhole camera. Output is a
pure function of the input dict: the same view always yields byte-identical PNG bytes.
"""

from __future__ import annotations

import colorsys
import functools
import inspect
import io
import math
import struct
import threading
import zlib
from collections import OrderedDict
from dataclasses import dataclass
from typing import Any

from PIL import Image, ImageDraw, ImageFont

MIN_SIZE = 300
STRIP_HEIGHT = 28
EYE_HEIGHT = 0.6  # camera above the agent's reported position (metres), roughly THOR's
MIN_DEPTH = 0.3  # clamp depth so objects at the agent's feet do not blow up to infinity
WALL, FLOOR, HORIZON = (226, 218, 200), (150, 132, 112), (110, 95, 80)
# (width, height) in metres for a few big types; sizes make the scene readable, not exact.
TYPE_SIZES = {
    "Fridge": (0.7, 1.7),
    "CounterTop": (1.1, 0.12),
    "DiningTable": (1.0, 0.12),
    "Cabinet": (0.5, 0.45),
    "Drawer": (0.45, 0.18),
    "Sink": (0.6, 0.2),
    "Microwave": (0.5, 0.3),
    "StoveBurner": (0.3, 0.08),
    "Shelf": (0.8, 0.1),
}
Box = tuple[float, float, float, float]
#: How many pictures are kept by what they show (`_picture_key`): an agent sees the same view
#: again and again (a Find brings it back to the same spot), and a picture takes ~1 ms to draw.
PICTURES_KEPT = 64
_pictures: OrderedDict[tuple, _KeptPicture] = OrderedDict()
#: Guards the kept pictures and labels (`_kept`).
_kept_lock = threading.Lock()


#: How many label measurements and rasterised labels the font keeps (each a few hundred bytes).
GLYPHS_KEPT = 4096


@functools.lru_cache(maxsize=4)
def _font(size: int = 12) -> ImageFont.ImageFont:
    # Pillow >= 10.1 ships a scalable default font; older versions only the tiny bitmap one.
    # Loaded once: loading it took a tenth of a frame's time.
    try:
        default = ImageFont.load_default(size=size)
    except TypeError:
        return ImageFont.load_default()
    if not isinstance(default, ImageFont.FreeTypeFont):
        return default
    return _KeptLabelsFont(io.BytesIO(default.font_bytes), default.size, default.index,
                           default.encoding, default.layout_engine)


class _KeptLabelsFont(ImageFont.FreeTypeFont):
    """The default font, keeping each label it measured or rasterised: FreeType took ~0.6 ms
    to measure a label and ~1.4 ms to rasterise it, three quarters of a picture's drawing,
    and the same labels come back picture after picture (the same objects, often at the
    same place). The results are FreeType's own, kept by every argument they depend on, so
    the pixels are those of an uncached font."""

    def getbbox(self, text, *args, **kwargs):
        return _kept(_boxes, (self.size, *_key(text, args, kwargs)),
                     lambda: super(_KeptLabelsFont, self).getbbox(text, *args, **kwargs))

    def getmask2(self, text, *args, **kwargs):
        # A mask is only read (ImageDraw.draw_bitmap pastes it), so one object can serve.
        return _kept(_masks, self._mask_key(text, args, kwargs),
                     lambda: super(_KeptLabelsFont, self).getmask2(text, *args, **kwargs))

    def _mask_key(self, text, args: tuple, kwargs: dict) -> tuple:
        """`_key`, with the sub-pixel start as the pixels it rounds to where that is all
        the mask depends on. A label is drawn at a fractional place, so keyed by its exact
        start nearly every picture missed (1,065 masks for 47 labels in 2,800 pictures)."""
        named = dict(zip(_MASK_PARAMETERS, args))
        named.update(kwargs)
        start = named.get("start")
        if start is not None and self._start_rounds_whole(text, named):
            rounded = _start_pixels(start)
            if rounded is not None:
                if "start" in kwargs:
                    kwargs = {**kwargs, "start": rounded}
                args = tuple(rounded if name == "start" else value
                             for name, value in zip(_MASK_PARAMETERS, args))
                return (self.size, "start rounded", *_key(text, args, kwargs))
        return (self.size, *_key(text, args, kwargs))

    def _start_rounds_whole(self, text, named: dict) -> bool:
        """Whether this call's mask depends on its start only through `_start_pixels`:
        FreeType's own layout (not Raqm's), no direction, features or stroke, a greyscale
        mask, and a pen that stays on whole pixels glyph to glyph (hinted advances). Pillow
        puts each glyph at PIXEL(pen + round(start * 64)), the pen in 1/64 px."""
        if (self.layout_engine != ImageFont.Layout.BASIC or named.get("mode") != "L"
                or named.get("direction") is not None or named.get("features") is not None
                or named.get("stroke_width", 0) != 0):
            return False
        return _kept(_pens, (self.size, text), lambda: all(
            self.getlength(text[:end], "L").is_integer()
            and self.getlength(text[end - 1], "L").is_integer()
            for end in range(1, len(text) + 1)))


#: getmask2's parameters in the order ImageDraw.text passes them (after the text).
_MASK_PARAMETERS = tuple(inspect.signature(ImageFont.FreeTypeFont.getmask2).parameters)[2:]
#: A start this close (in 1/64 px) to a rounding boundary keeps its exact value as its key:
#: Pillow adds it to the text's integer origin in single precision before rounding.
_BOUNDARY_MARGIN = 0.01


def _start_pixels(start) -> tuple | None:
    """What a sub-pixel start (x, y in [0, 1)) changes in FreeType's mask, as Pillow's
    `font_render` computes it: the mask widens by ceil(start) (0 only at 0), and the glyphs
    move one pixel right once round(x * 64) >= 32 (PIXEL rounds half up) and one pixel up
    once round(y * 64) >= 33 (y is negated first); the start is a C float there. None for a
    start outside [0, 1) or near a boundary."""
    rounded = []
    for value, threshold in zip(start, (32, 33)):
        single = struct.unpack("f", struct.pack("f", value))[0]
        if not 0.0 <= single < 1.0:
            return None
        sixty_fourths = single * 64  # exact: a power of two
        if abs(sixty_fourths - math.floor(sixty_fourths) - 0.5) < _BOUNDARY_MARGIN:
            return None
        rounded.append((single > 0, math.floor(sixty_fourths + 0.5) >= threshold))
    return tuple(rounded)


_boxes: OrderedDict[tuple, Any] = OrderedDict()
_masks: OrderedDict[tuple, Any] = OrderedDict()
#: Per label: whether its pen stays on whole pixels (`_KeptLabelsFont._start_rounds_whole`).
_pens: OrderedDict[tuple, bool] = OrderedDict()


def _key(text, args: tuple, kwargs: dict) -> tuple:
    """Every argument of a font call as a cache key (a list, e.g. OpenType features, as a
    tuple; the rest are Pillow's scalars and the start's tuple)."""
    def hashable(value):
        return tuple(value) if isinstance(value, list) else value
    return (text, tuple(map(hashable, args)),
            tuple((name, hashable(value)) for name, value in sorted(kwargs.items())))


def _kept(cache: OrderedDict, key: tuple, make, limit: int = GLYPHS_KEPT) -> Any:
    """`cache[key]`, made by `make()` when missing (outside the lock: drawing is the slow
    part); the least recently used dropped past `limit`. The pictures' and the labels'
    caches alike."""
    with _kept_lock:
        if key in cache:
            cache.move_to_end(key)
            return cache[key]
    value = make()
    with _kept_lock:
        cache[key] = value
        while len(cache) > limit:
            cache.popitem(last=False)
    return value


def type_colour(object_type: str) -> tuple[int, int, int]:
    """Stable colour for an object type (crc32, unlike hash(), is not salted per process)."""
    h = zlib.crc32(object_type.encode("utf-8"))
    hue, sat = (h % 360) / 360.0, 0.45 + ((h >> 9) % 30) / 100.0
    r, g, b = colorsys.hsv_to_rgb(hue, sat, 0.85)
    return int(r * 255), int(g * 255), int(b * 255)


def object_label(obj: dict) -> str:
    """Type plus the state words a planner cares about, e.g. ``Fridge (open)``."""
    states = []
    if obj.get("openable"):
        states.append("open" if obj.get("isOpen") else "closed")
    if obj.get("toggleable"):
        states.append("on" if obj.get("isToggled") else "off")
    for key, word in (("isSliced", "sliced"), ("isCooked", "cooked"), ("isDirty", "dirty")):
        if obj.get(key):
            states.append(word)
    name = obj.get("objectType") or str(obj.get("objectId", "?")).split("|")[0]
    return f"{name} ({', '.join(states)})" if states else name


class _Camera:
    """Pinhole camera at the agent's eye; converts world x-z-y points to screen coordinates."""

    def __init__(self, view: dict, width: int, height: int):
        agent = view.get("agent") or {}
        pos, rot = agent.get("position") or {}, agent.get("rotation") or {}
        self.x, self.z = float(pos.get("x", 0.0)), float(pos.get("z", 0.0))
        self.eye = float(pos.get("y", 0.9)) + EYE_HEIGHT
        self.yaw = math.radians(float(rot.get("y", 0.0)))
        self.fov = min(max(float(view.get("fieldOfView", 90) or 90), 10.0), 170.0)
        self.reach = float(view.get("visibilityDistance", 1.5) or 1.5)
        self.w, self.h = width, height
        self.focal = (width / 2) / math.tan(math.radians(self.fov / 2))
        # Positive cameraHorizon looks down, which moves the world horizon up the image.
        tilt = math.radians(float(agent.get("cameraHorizon", 0.0) or 0.0))
        self.horizon = min(max(height / 2 - self.focal * math.tan(tilt), 0.0), float(height))

    def local(self, pos: dict) -> tuple[float, float, float]:
        """(forward, lateral, horizontal distance); yaw 0 faces +z, yaw 90 faces +x."""
        dx, dz = float(pos.get("x", 0.0)) - self.x, float(pos.get("z", 0.0)) - self.z
        s, c = math.sin(self.yaw), math.cos(self.yaw)
        return dx * s + dz * c, dx * c - dz * s, math.hypot(dx, dz)

    def sees(self, pos: dict) -> bool:
        """Inside the horizontal view cone and within the visibility distance."""
        fwd, lat, dist = self.local(pos)
        in_cone = dist < 1e-6 or abs(math.degrees(math.atan2(lat, fwd))) <= self.fov / 2
        return in_cone and dist <= self.reach

    def project(self, pos: dict, size_m: tuple[float, float]) -> Box:
        """Screen box of an object of the given metric size centred at ``pos``."""
        fwd, lat, _ = self.local(pos)
        depth = max(fwd, MIN_DEPTH)
        cx = self.w / 2 + self.focal * lat / depth
        cy = self.horizon + self.focal * (self.eye - float(pos.get("y", 0.9))) / depth
        bw = min(max(self.focal * size_m[0] / depth, 10.0), self.w * 0.9)
        bh = min(max(self.focal * size_m[1] / depth, 10.0), self.h * 0.8)
        # Keep the whole shape on screen: a schematic view must never lose an object it lists.
        cx = min(max(cx, bw / 2 + 2), self.w - bw / 2 - 2)
        cy = min(max(cy, bh / 2 + 20), self.h - bh / 2 - 22)
        return cx - bw / 2, cy - bh / 2, cx + bw / 2, cy + bh / 2


def _hidden_in_closed(obj: dict, by_id: dict) -> bool:
    # Contents of a closed fridge/drawer cannot be seen, even though they are in the cone.
    for pid in obj.get("parentReceptacles") or []:
        parent = by_id.get(pid)
        if parent and parent.get("openable") and not parent.get("isOpen"):
            return True
    return False


def _visible_items(view: dict, cam: _Camera) -> list[tuple[float, str, dict]]:
    """(distance, kind, record) of everything to draw, farthest first (painter's order)."""
    objects = view.get("objects") or []
    by_id = {o.get("objectId"): o for o in objects}
    held = {o.get("objectId") for o in view.get("inventoryObjects") or []}
    items = []
    for obj in objects:
        if obj.get("isPickedUp") or obj.get("objectId") in held or not obj.get("position"):
            continue
        if cam.sees(obj["position"]) and not _hidden_in_closed(obj, by_id):
            items.append((cam.local(obj["position"])[2], "object", obj))
    for other in view.get("otherAgents") or []:
        if other.get("position") and cam.sees(other["position"]):
            items.append((cam.local(other["position"])[2], "agent", other))
    # Ties broken by id/name so the drawing order never depends on input order quirks.
    items.sort(key=lambda it: (-it[0], it[1], str(it[2].get("objectId") or it[2].get("name"))))
    return items


@functools.lru_cache(maxsize=32)
def _room(w: int, h: int, horizon: float) -> Image.Image:
    """The static room of a camera (wall, floor, its lines, the horizon), drawn once per size
    and tilt; each frame draws on a copy."""
    img = Image.new("RGB", (w, h), WALL)
    draw = ImageDraw.Draw(img)
    draw.rectangle((0, horizon, w, h), fill=FLOOR)
    # Floor lines converging to the centre give a sense of depth and of the camera tilt.
    for k in range(-4, 5):
        draw.line((w / 2 + k * 12, horizon, w / 2 + k * w / 3, h), fill=(140, 122, 103))
    draw.line((0, horizon, w, horizon), fill=HORIZON, width=2)
    return img


def _draw_object(draw: ImageDraw.ImageDraw, obj: dict, box: Box) -> None:
    fill = type_colour(str(obj.get("objectType", "")))
    outline, (x0, y0, x1, y1) = tuple(v // 2 for v in fill), box
    # Receptacles (furniture) are boxes, portable things are round: readable at a glance.
    shape = draw.rectangle if obj.get("receptacle") else draw.ellipse
    shape(box, fill=fill, outline=outline, width=2)
    if obj.get("openable") and obj.get("isOpen"):
        # Dark interior plus a swung door on the right: "open" is readable without the label.
        inset = min(x1 - x0, y1 - y0) * 0.15
        draw.rectangle((x0 + inset, y0 + inset, x1 - inset, y1 - inset), fill=(45, 45, 50))
        draw.polygon(
            [(x1, y0), (x1 + (x1 - x0) * 0.25, y0 + 4), (x1 + (x1 - x0) * 0.25, y1 - 4), (x1, y1)],
            fill=fill,
            outline=outline,
        )
    elif obj.get("openable"):
        draw.line((x1 - 6, y0 + 4, x1 - 6, y1 - 4), fill=outline, width=2)  # door handle
    if obj.get("isSliced"):
        for f in (0.33, 0.66):
            draw.line((x0 + (x1 - x0) * f, y0, x0 + (x1 - x0) * f, y1), fill=(255, 255, 255))
    if obj.get("toggleable") and obj.get("isToggled"):
        draw.ellipse((x0 + 2, y0 + 2, x0 + 10, y0 + 10), fill=(255, 230, 40), outline=outline)


def _draw_agent(draw: ImageDraw.ImageDraw, box: Box) -> None:
    # A stick-robot silhouette in blue, so agents never look like household objects.
    x0, y0, x1, y1 = box
    cx, head = (x0 + x1) / 2, (y1 - y0) * 0.22
    draw.ellipse((cx - head / 2, y0, cx + head / 2, y0 + head), fill=(40, 70, 160))
    draw.polygon(
        [(cx - head * 0.4, y0 + head), (cx + head * 0.4, y0 + head), (x1, y1), (x0, y1)],
        fill=(60, 100, 200),
        outline=(20, 40, 100),
    )


def _place_label(draw, text: str, box: Box, font, taken: list[Box], w: int, h: int) -> Box:
    """Label box just above (else below) the shape, stepping away until no label overlaps."""
    left, top, right, bottom = _text_box(draw, text, font)
    tw, th = right - left + 6, bottom - top + 4
    x = min(max((box[0] + box[2]) / 2 - tw / 2, 1), w - tw - 1)
    above, below = box[1] - th - 2, box[3] + 2
    # Alternate above/below so a label never lands on top of its own (small) shape.
    for y in (v for k in range(8) for v in (above - k * (th + 1), below + k * (th + 1))):
        y = min(max(y, 1), h - th - 1)
        cand = (x, y, x + tw, y + th)
        if not any(
            c[0] < cand[2] and cand[0] < c[2] and c[1] < cand[3] and cand[1] < c[3] for c in taken
        ):
            break
    taken.append(cand)
    return cand


def _held_box(draw, view: dict, font, w: int, h: int) -> tuple[str, Box] | None:
    """Text and bottom-right box of the ``holding: ...`` badge, or None when empty-handed."""
    held = [
        str(o.get("objectType") or o.get("objectId")) for o in view.get("inventoryObjects") or []
    ]
    if not held:
        return None
    text = "holding: " + ", ".join(held)
    bb = _text_box(draw, text, font)
    return text, (w - (bb[2] - bb[0]) - 14, h - (bb[3] - bb[1]) - 12, w - 4, h - 4)


def _png(img: Image.Image) -> bytes:
    # No pnginfo and no optimisation: the bytes depend only on the pixels.
    buf = io.BytesIO()
    img.save(buf, format="PNG")
    return buf.getvalue()


def render_agent_frame(view: dict, width: int = 300, height: int = 300) -> bytes:
    """PNG bytes of what one agent sees (schematic first-person view, deterministic): the
    picture `draw_agent_view` draws."""
    return _png(draw_agent_view(view, width, height))


def draw_agent_view(view: dict, width: int = 300, height: int = 300) -> Image.Image:
    """The RGB picture of what one agent sees (schematic first-person view, deterministic).

    Objects inside the horizontal view cone and within ``visibilityDistance`` (and not held) are
    drawn far-to-near with ``Type (state)`` labels; other agents appear as blue figures labelled
    with their name; the held object is shown as ``holding: Type`` in the bottom-right corner.
    Width and height are clamped up to at least 300 px. The picture may be shared with an
    earlier call that showed the same: copy it before drawing on it.
    """
    kept = _kept_picture(view, width, height)
    if kept.picture is None:  # made once per picture kept (a race makes it twice, alike)
        picture = _room(*kept.size, kept.horizon).copy()
        if kept.part is not None:
            picture.paste(kept.part, kept.drawn[:2])
        kept.picture = picture
    return kept.picture


def agent_view_pixels(view: dict, width: int = 300, height: int = 300, out: Any = None) -> Any:
    """`draw_agent_view`'s picture as an RGB numpy array (height, width, 3), written into
    `out` (a uint8 array of that shape) when given, else into a new array: the room's
    pixels, then the part drawn on them (kept with the picture). Written, not copied from
    a kept whole picture: the room's pixels are shared by every picture of a camera tilt,
    so they stay in the processor's cache, where 64 kept pictures' (17 MB) did not (the
    team's frames took a quarter of a C0_image step to copy)."""
    import numpy  # here: only environments read pixels, and numpy takes a while to import

    kept = _kept_picture(view, width, height)
    w, h = kept.size
    pixels = numpy.empty((h, w, 3), numpy.uint8) if out is None else out
    pixels[...] = _room_pixels(w, h, kept.horizon)
    if kept.part is not None:
        left, top, right, bottom = kept.drawn
        if kept.patch is None:  # read once per picture kept (a race reads it twice, alike)
            patch = numpy.asarray(kept.part)
            patch.flags.writeable = False
            kept.patch = patch
        pixels[top:bottom, left:right] = kept.patch
    return pixels


@dataclass
class _KeptPicture:
    """A picture as drawn: its size, its camera's horizon (which room), the part drawn on
    the room and the whole-pixel box it covers (None for both: nothing is); then, made when
    first asked for, the part's pixels and the whole picture."""

    size: tuple[int, int]
    horizon: float
    part: Image.Image | None
    drawn: Box | None
    patch: Any = None
    picture: Image.Image | None = None


def _kept_picture(view: dict, width: int, height: int) -> _KeptPicture:
    """The picture of `view`, drawn or the kept one that shows the same."""
    w, h = max(int(width), MIN_SIZE), max(int(height), MIN_SIZE)
    cam = _Camera(view, w, h)
    items = _visible_items(view, cam)
    return _kept(_pictures, _picture_key(cam, items, view),
                 lambda: _KeptPicture((w, h), cam.horizon, *_draw_view(view, cam, items)),
                 PICTURES_KEPT)


def _picture_key(cam: _Camera, items: list[tuple[float, str, dict]], view: dict) -> tuple:
    """Everything a picture shows: the camera, each drawn thing's kind, label, place and the
    states its shape shows, in drawing order, and what the agent holds."""
    drawn = tuple(
        (kind, str(rec.get("name", "agent")) if kind == "agent" else object_label(rec),
         tuple(rec["position"].get(axis) for axis in "xyz"), rec.get("objectType"),
         *(bool(rec.get(state)) for state in _SHOWN_STATES))
        for _, kind, rec in items
    )
    held = tuple(
        str(o.get("objectType") or o.get("objectId")) for o in view.get("inventoryObjects") or []
    )
    return (cam.w, cam.h, cam.x, cam.z, cam.eye, cam.yaw, cam.fov, cam.reach, cam.horizon,
            drawn, held)


#: The states `_draw_object` shows by the shape (the label shows its own).
_SHOWN_STATES = ("receptacle", "openable", "isOpen", "isSliced", "toggleable", "isToggled")


def _draw_view(view: dict, cam: _Camera, items: list[tuple[float, str, dict]]
               ) -> tuple[Image.Image | None, Box | None]:
    """What is drawn on the room, as a picture of the whole-pixel box that holds it all, and
    that box (None and None when nothing is drawn). Laid out first (every shape's box, every
    label's place), then painted on that box alone, in the same order: copying the whole
    room to paint on, and reading the box back out of it, cost an eighth of a picture drawn
    (350 -> 307 us)."""
    w, h = cam.w, cam.h
    room = _room(w, h, cam.horizon)
    measure = ImageDraw.Draw(room)  # measures labels only: nothing is drawn on the room
    font = _font()
    shapes: list[tuple[str, dict, Box]] = []
    labels: list[tuple[str, Box]] = []
    extents: list[Box] = []
    for _, kind, rec in items:
        if kind == "agent":
            box = cam.project(rec["position"], (0.45, 1.1))
            labels.append((str(rec.get("name", "agent")), box))
            extents.append(box)
        else:
            default = (0.45, 0.3) if rec.get("receptacle") else (0.18, 0.18)
            box = cam.project(rec["position"], TYPE_SIZES.get(rec.get("objectType"), default))
            labels.append((object_label(rec), box))
            x0, y0, x1, y1 = box  # an open door swings out a quarter of the width on the right
            extents.append((x0, y0, x1 + (x1 - x0) * 0.25, y1) if rec.get("openable") else box)
        shapes.append((kind, rec, box))
    held = _held_box(measure, view, font, w, h)
    # The badge's area is reserved first so object labels are never hidden beneath it.
    taken = [held[1]] if held else []
    # Labels go on top of all shapes so a near object never hides a far object's name.
    placed = [(text, _place_label(measure, text, box, font, taken, w, h))
              for text, box in labels]
    drawn = _drawn_box([*extents, *taken], w, h)
    if drawn is None:
        return None, None
    part = room.crop(drawn)
    draw = _Shifted(part, drawn[0], drawn[1])
    for kind, rec, box in shapes:
        if kind == "agent":
            _draw_agent(draw, box)
        else:
            _draw_object(draw, rec, box)
    for text, lb in placed:
        draw.label(text, lb, _LABEL, font)
    if held:
        draw.label(held[0], held[1], _BADGE, font)
    return part, drawn


class _Shifted:
    """Draws on a part of the picture (the drawn box) given the picture's coordinates: each
    is computed as on the whole picture, then moved by the part's whole-pixel corner, which
    is exact, so Pillow rounds it to the same pixel of the part."""

    def __init__(self, part: Image.Image, left: int, top: int) -> None:
        self.part, self.draw, self.left, self.top = part, ImageDraw.Draw(part), left, top

    def rectangle(self, xy: Box, **kwargs: Any) -> None:
        self.draw.rectangle(self._box(xy), **kwargs)

    def ellipse(self, xy: Box, **kwargs: Any) -> None:
        self.draw.ellipse(self._box(xy), **kwargs)

    def line(self, xy: Box, **kwargs: Any) -> None:
        self.draw.line(self._box(xy), **kwargs)

    def polygon(self, points: list[tuple[float, float]], **kwargs: Any) -> None:
        self.draw.polygon([(x - self.left, y - self.top) for x, y in points], **kwargs)

    def label(self, text: str, box: Box, style: _LabelStyle, font: Any) -> None:
        """`text` in a box drawn in `style`: the kept pixels of a label drawn alike
        (`_label_patch`) pasted, else drawn here."""
        rect = self._box(box)
        start = (box[0] + style.inset[0] - self.left, box[1] + style.inset[1] - self.top)
        kept = _label_patch(text, rect, start, style, font)
        if kept is None:
            style.draw(self.draw, rect, start, text, font)
        else:
            patch, (dx, dy) = kept
            self.part.paste(patch, (int(rect[0]) + dx, int(rect[1]) + dy))

    def _box(self, xy: Box) -> Box:
        x0, y0, x1, y1 = xy
        return x0 - self.left, y0 - self.top, x1 - self.left, y1 - self.top


@dataclass(frozen=True)
class _LabelStyle:
    """How a label's box is drawn, and where in it its text starts."""

    fill: tuple[int, int, int]
    outline: tuple[int, int, int]
    width: int
    inset: tuple[int, int]

    def draw(self, draw: ImageDraw.ImageDraw, rect: Box, start: tuple[float, float],
             text: str, font: Any) -> None:
        draw.rectangle(rect, fill=self.fill, outline=self.outline, width=self.width)
        draw.text(start, text, fill=(0, 0, 0), font=font, anchor="lt")


_LABEL = _LabelStyle((255, 255, 255), (90, 90, 90), 1, (3, 2))  # an object's or agent's name
_BADGE = _LabelStyle((255, 244, 190), (120, 100, 30), 2, (5, 4))  # "holding: ..."
#: How many labels' pixels are kept (`_label_patch`; each a few kB).
LABELS_KEPT = 1024
_labels: OrderedDict[tuple, Any] = OrderedDict()
_text_boxes: OrderedDict[tuple, Any] = OrderedDict()
#: Room around a label's box on the canvas it is first drawn on, for pixels outside the box.
_LABEL_MARGIN = 2


def _text_box(draw: ImageDraw.ImageDraw, text: str, font: Any) -> tuple:
    """`draw.textbbox((0, 0), text, font=font)`, kept per font and text (Pillow's text
    layout took ~10 us a label even with the font's boxes kept)."""
    return _kept(_text_boxes, (font, draw.fontmode, text),
                 lambda: draw.textbbox((0, 0), text, font=font))


def _label_patch(text: str, rect: Box, start: tuple[float, float], style: _LabelStyle,
                 font: Any) -> tuple[Image.Image, tuple[int, int]] | None:
    """The pixels of a label drawn in `style` with its box at `rect` and its text at `start`
    (a part's coordinates), and where they go from the box's whole-pixel corner; None where
    they cannot be kept (a font that is not `_KeptLabelsFont`, a box left of or above the
    part, a start whose mask is not kept by its rounding, text drawn outside its box).

    Pillow draws a box at the whole pixels of its corners (`int()`), and text at its
    start's whole pixels with the mask of its sub-pixel part; so the label is the same
    pixels at any whole-pixel shift of these, and is kept by them relative to the corner
    and the mask's key. Drawn once on a clear canvas and pasted after, where drawing it
    (box, then text blended onto it) took ~75 us, a quarter of a picture drawn."""
    if not isinstance(font, _KeptLabelsFont) or min(rect[0], rect[1]) < 0:
        return None  # (int() is floor only from 0 up)
    # The text's mask as the font keeps it (`_KeptLabelsFont._mask_key`): a label's text is
    # greyscale, with no direction, features or stroke.
    rounded = _start_pixels((math.modf(start[0])[0], math.modf(start[1])[0]))
    if rounded is None or not font._start_rounds_whole(text, {"mode": "L"}):
        return None
    x0, y0 = int(rect[0]), int(rect[1])
    key = (style, font.size, text, rounded, int(rect[2]) - x0, int(rect[3]) - y0,
           int(start[0]) - x0, int(start[1]) - y0)
    return _kept(_labels, key, lambda: _draw_label(text, rect, start, style, font, x0, y0),
                 LABELS_KEPT)


def _draw_label(text: str, rect: Box, start: tuple[float, float], style: _LabelStyle,
                font: Any, x0: int, y0: int) -> tuple[Image.Image, tuple[int, int]] | None:
    """`_label_patch`'s pixels: the label drawn on a clear canvas shifted by whole pixels
    (subtracting an integer from these positive coordinates is exact), cut to what was
    drawn, which must be a solid box clear of the canvas's edges (else None: the text
    leaves its box)."""
    margin = _LABEL_MARGIN
    sx, sy = x0 - margin, y0 - margin
    size = (int(rect[2]) - x0 + 1 + 2 * margin, int(rect[3]) - y0 + 1 + 2 * margin)
    canvas = Image.new("RGBA", size, (0, 0, 0, 0))
    style.draw(ImageDraw.Draw(canvas), (rect[0] - sx, rect[1] - sy, rect[2] - sx, rect[3] - sy),
               (start[0] - sx, start[1] - sy), text, font)
    alpha = canvas.getchannel("A")
    drawn = alpha.getbbox()
    if (drawn is None or alpha.crop(drawn).getextrema() != (255, 255)
            or 0 in drawn[:2] or drawn[2] == size[0] or drawn[3] == size[1]):
        return None
    return canvas.crop(drawn).convert("RGB"), (drawn[0] - margin, drawn[1] - margin)


#: Pixels around a drawn shape's box that its rasterised edge may touch (Pillow rounds the
#: corners of a box at fractional coordinates outwards by at most one).
_EDGE = 2


def _drawn_box(boxes: list[Box], w: int, h: int) -> Box | None:
    """The whole-pixel box holding every box drawn (each widened by `_EDGE`), within the
    picture; None when none is."""
    if not boxes:
        return None
    left = max(math.floor(min(b[0] for b in boxes)) - _EDGE, 0)
    top = max(math.floor(min(b[1] for b in boxes)) - _EDGE, 0)
    right = min(math.ceil(max(b[2] for b in boxes)) + _EDGE + 1, w)
    bottom = min(math.ceil(max(b[3] for b in boxes)) + _EDGE + 1, h)
    return (left, top, right, bottom) if left < right and top < bottom else None


@functools.lru_cache(maxsize=32)
def _room_pixels(w: int, h: int, horizon: float) -> Any:
    """`_room`'s pixels (read-only: each picture's are a copy)."""
    import numpy

    return numpy.asarray(_room(w, h, horizon))


def merge_agent_frames(frames: list[tuple[str, bytes]]) -> bytes:
    """Side-by-side PNG of several agents' frames, each under a 28-px white label strip.

    ``frames`` is ``[(agent_id, png_bytes), ...]``; strips are concatenated left to right in
    the given order, the agent id drawn in black at (8, 7) of its strip (reference §6.4).
    """
    if not frames:
        raise ValueError("merge_agent_frames needs at least one frame")
    images = [(name, Image.open(io.BytesIO(data)).convert("RGB")) for name, data in frames]
    total_w = sum(img.width for _, img in images)
    total_h = max(img.height for _, img in images) + STRIP_HEIGHT
    merged = Image.new("RGB", (total_w, total_h), (255, 255, 255))
    draw, font, x = ImageDraw.Draw(merged), _font(), 0
    for name, img in images:
        merged.paste(img, (x, STRIP_HEIGHT))
        draw.text((x + 8, 7), str(name), fill=(0, 0, 0), font=font)
        x += img.width
    return _png(merged)
