"""Tests for the embedded simulator's egocentric frame renderer."""

from __future__ import annotations

import io

from hypothesis import given, settings
from hypothesis import strategies as st
from PIL import Image, ImageChops

from benchmark_adapter.sim.embedded.render import (
    merge_agent_frames,
    render_agent_frame,
)

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def _pos(x: float, y: float, z: float) -> dict:
    return {"x": x, "y": y, "z": z}


def _obj(object_type: str, pos: dict, **state) -> dict:
    obj = {
        "objectId": f"{object_type}|{pos['x']:+.2f}|{pos['y']:+.2f}|{pos['z']:+.2f}",
        "objectType": object_type,
        "position": pos,
        "visible": True,
        "isOpen": False,
        "openable": False,
        "isToggled": False,
        "toggleable": False,
        "isSliced": False,
        "isPickedUp": False,
        "receptacle": False,
        "receptacleObjectIds": None,
        "parentReceptacles": None,
    }
    obj.update(state)
    return obj


def _view(objects=(), others=(), inventory=(), yaw: float = 0.0, horizon: float = 0.0) -> dict:
    return {
        "agent": {
            "name": "agent_1",
            "position": _pos(0.0, 0.9, 0.0),
            "rotation": {"x": 0, "y": yaw, "z": 0},
            "cameraHorizon": horizon,
        },
        "visibilityDistance": 1.5,
        "fieldOfView": 90,
        "objects": list(objects),
        "otherAgents": list(others),
        "inventoryObjects": list(inventory),
    }


def _img(data: bytes) -> Image.Image:
    return Image.open(io.BytesIO(data)).convert("RGB")


def _kitchen() -> dict:
    return _view(
        objects=[
            _obj("Fridge", _pos(-0.6, 0.9, 1.3), openable=True, isOpen=True, receptacle=True),
            _obj("CounterTop", _pos(0.3, 0.9, 1.0), receptacle=True),
            _obj("Tomato", _pos(0.25, 0.98, 0.9), isSliced=True),
        ],
        others=[
            {
                "name": "agent_2",
                "position": _pos(0.5, 0.9, 1.2),
                "rotation": {"x": 0, "y": 180, "z": 0},
            }
        ],
        inventory=[{"objectId": "Knife|+0.10|+0.90|+0.50", "objectType": "Knife"}],
        horizon=30,
    )


def test_png_signature_and_default_size():
    data = render_agent_frame(_kitchen())
    assert data.startswith(PNG_SIGNATURE)
    assert _img(data).size == (300, 300)


def test_size_is_clamped_up_to_300():
    assert _img(render_agent_frame(_view(), width=100, height=50)).size == (300, 300)
    assert _img(render_agent_frame(_view(), width=400, height=320)).size == (400, 320)


def test_deterministic_bytes():
    assert render_agent_frame(_kitchen()) == render_agent_frame(_kitchen())


def test_object_in_front_changes_picture():
    empty = render_agent_frame(_view())
    with_apple = render_agent_frame(_view([_obj("Apple", _pos(0.0, 0.9, 1.0))]))
    assert with_apple != empty


def test_object_in_front_respects_yaw():
    # Yaw 90 faces +x: an apple at +x is seen, an apple at +z (now to the left, 90 deg) is not.
    empty = render_agent_frame(_view(yaw=90))
    assert render_agent_frame(_view([_obj("Apple", _pos(1.0, 0.9, 0.0))], yaw=90)) != empty
    assert render_agent_frame(_view([_obj("Apple", _pos(0.0, 0.9, 1.0))], yaw=90)) == empty


def test_object_behind_or_too_far_or_held_is_not_drawn():
    empty = render_agent_frame(_view())
    behind = _obj("Apple", _pos(0.0, 0.9, -1.0))
    too_far = _obj("Apple", _pos(0.0, 0.9, 2.0))
    picked = _obj("Apple", _pos(0.0, 0.9, 1.0), isPickedUp=True)
    for obj in (behind, too_far, picked):
        assert render_agent_frame(_view([obj])) == empty


def test_other_agent_in_view_is_drawn():
    empty = render_agent_frame(_view())
    other = {"name": "agent_2", "position": _pos(0.0, 0.9, 1.0), "rotation": {"y": 180}}
    assert render_agent_frame(_view(others=[other])) != empty
    other_behind = dict(other, position=_pos(0.0, 0.9, -1.0))
    assert render_agent_frame(_view(others=[other_behind])) == empty


def test_state_changes_picture():
    closed = _obj("Fridge", _pos(0.0, 0.9, 1.2), openable=True, receptacle=True)
    opened = dict(closed, isOpen=True)
    assert render_agent_frame(_view([closed])) != render_agent_frame(_view([opened]))


def test_holding_label_in_bottom_right():
    knife = [{"objectId": "Knife|+0.10|+0.90|+0.50", "objectType": "Knife"}]
    plain = _img(render_agent_frame(_view()))
    holding = _img(render_agent_frame(_view(inventory=knife)))
    corner = (150, 260, 300, 300)
    assert ImageChops.difference(plain.crop(corner), holding.crop(corner)).getbbox() is not None
    # Only the corner changes: the rest of the frame is untouched.
    top = (0, 0, 300, 200)
    assert ImageChops.difference(plain.crop(top), holding.crop(top)).getbbox() is None


def test_merge_three_agents():
    frames = [(f"agent_{i}", render_agent_frame(_kitchen())) for i in (1, 2, 3)]
    merged = _img(merge_agent_frames(frames))
    assert merged.size == (900, 328)
    # The strip is white apart from the black agent ids drawn at (8, 7).
    strip = merged.crop((0, 0, 900, 28))
    assert strip.getpixel((299, 27)) == (255, 255, 255)
    assert strip.crop((8, 7, 60, 22)).convert("L").getextrema()[0] < 100
    # Frames are pasted in order below the strip.
    assert merged.crop((300, 28, 600, 328)).tobytes() == _img(frames[1][1]).tobytes()


def test_the_kept_labels_font_draws_as_freetype_does():
    """The renderer's font keeps each label it rasterised and measured (a frame drew each
    label afresh, three quarters of its time): what it gives back, first call or kept, is
    FreeType's own result for those arguments, at every sub-pixel start a label is drawn at.
    A mask is kept by the pixels its start rounds to, so the starts include those beside
    the rounding boundaries (31.5 / 64 across, 32.5 / 64 down) and a mask kept at another
    start of the same side must be the one FreeType draws."""
    import random

    from PIL import ImageDraw, ImageFont

    from benchmark_adapter.sim.embedded.render import _font

    kept, plain = _font(), ImageFont.load_default(size=12)
    rng = random.Random(7)
    edges = [edge + nudge for edge in (0.0, 31.5 / 64, 32.5 / 64, 63.5 / 64)
             for nudge in (0.0, 1e-7, -1e-7, 0.02 / 64, -0.02 / 64) if edge + nudge >= 0]
    for text in ("Fridge (closed)", "Apple", "holding: Knife, Mug", "agent_2", "AVA To Wa"):
        assert kept.getbbox(text) == plain.getbbox(text)
        for _ in range(120):
            start = (rng.choice([*edges, rng.random()]), rng.choice([*edges, rng.random()]))
            for _ in range(2):  # drawn, then kept
                mask, offset = kept.getmask2(text, "L", anchor="lt", start=start)
                expected, expected_offset = plain.getmask2(text, "L", anchor="lt", start=start)
                assert (bytes(mask), mask.size, offset) == \
                    (bytes(expected), expected.size, expected_offset)
    pictures = []
    for font in (kept, plain, kept):
        picture = Image.new("RGB", (120, 40), (255, 255, 255))
        ImageDraw.Draw(picture).text((3.3, 2.71), "Fridge (open)", fill=(0, 0, 0), font=font,
                                     anchor="lt")
        pictures.append(picture.tobytes())
    assert pictures[0] == pictures[1] == pictures[2]


@settings(max_examples=300, deadline=None)
@given(text=st.sampled_from(["Fridge (closed)", "Apple", "agent_2", "Mug (dirty)",
                             "holding: Knife, Mug"]) | st.text("AVWaTo (),:_.ji", max_size=14),
       x=st.floats(1, 150), y=st.floats(1, 60), left=st.integers(0, 3),
       top=st.integers(0, 3), badge=st.booleans(), seed=st.integers(0, 2**16))
def test_a_kept_label_is_the_pixels_drawing_it_gives(text, x, y, left, top, badge, seed):
    """A label is drawn once and its pixels pasted wherever a label of the same text, box
    size and sub-pixel start class comes back (a quarter of a picture's drawing): pasted
    or drawn, the picture is what Pillow draws there, on any background, at any fractional
    place (the box's corner and the text's start are fractional, the part's corner whole),
    the second time (kept) as the first."""
    import random

    from PIL import ImageDraw

    from benchmark_adapter.sim.embedded import render

    font = render._font()
    style = render._BADGE if badge else render._LABEL
    measure = ImageDraw.Draw(Image.new("RGB", (1, 1)))
    bbox = render._text_box(measure, text, font)
    box = (x, y, x + bbox[2] - bbox[0] + 6, y + bbox[3] - bbox[1] + 4)
    noise = random.Random(seed).randbytes(220 * 90 * 3)
    for _ in range(2):  # drawn (or pasted, kept from an earlier example), then kept
        part = Image.frombytes("RGB", (220, 90), noise)
        render._Shifted(part, left, top).label(text, box, style, font)
        expected = Image.frombytes("RGB", (220, 90), noise)
        style.draw(ImageDraw.Draw(expected), (x - left, y - top, box[2] - left, box[3] - top),
                   (x + style.inset[0] - left, y + style.inset[1] - top), text, font)
        assert part.tobytes() == expected.tobytes()
