"""The embedded simulator's frames, byte for byte: every agent's PNG (and C0's side-by-side
view) at every step of the oracle's plan on six shared configs (2, 3 and 4 agents; kitchens,
living rooms, bedrooms), hashed into one digest. Pinned before the renderer was made faster
(the static room drawn once, the env's frames kept as pixels): a prompt's frame must not
change by a byte. The digest changes only with a deliberate change of the picture."""

from __future__ import annotations

import hashlib

import pytest

from benchmark_adapter.episode import Episode
from benchmark_adapter.oracles import oracle_plan
from benchmark_adapter.sim.embedded.render import merge_agent_frames
from benchmark_adapter.tasks import load_task
from tests.paths import SHARED_TASKS

pytestmark = pytest.mark.slow

CONFIGS = ("A_D1__FloorPlan1__seed0", "C_D2__FloorPlan202__livingroom_3agent_seed1",
           "G_D1__FloorPlan224__4agent_seed0", "J_D4__FloorPlan307__bedroom_seed0",
           "K_D3__FloorPlan10__3agent_seed0", "H_D2__FloorPlan301__4agent_seed0")
DIGEST = "763763402b36740b4ef0a74bfdab37123b2074cefb94aa7f77eafe9fb5f1895c"


def frames_digest() -> str:
    digest = hashlib.sha256()
    for name in CONFIGS:
        config = load_task(SHARED_TASKS / f"{name}.json")
        episode = Episode(config)
        episode.reset()
        for call in [None, *oracle_plan(config)]:
            if call is not None:
                episode.step(call)
            frames = [(a, episode.frame(a)) for a in config.agent_ids]
            for _, png in frames:
                digest.update(png)
            digest.update(merge_agent_frames(frames))
    return digest.hexdigest()


def test_the_frames_bytes_are_pinned():
    assert frames_digest() == DIGEST


def test_the_pixels_an_environment_reads_are_the_pngs():
    """`Episode.frame_pixels` (the embedded simulator's pixels, no PNG made) is the PNG's
    picture, at reset and after steps, for every agent."""
    import io

    import numpy as np
    from PIL import Image

    config = load_task(SHARED_TASKS / f"{CONFIGS[1]}.json")
    episode = Episode(config)
    episode.reset()
    for call in [None, *list(oracle_plan(config))[:6]]:
        if call is not None:
            episode.step(call)
        for agent in config.agent_ids:
            png = np.asarray(Image.open(io.BytesIO(episode.frame(agent))).convert("RGB"))
            assert np.array_equal(episode.frame_pixels(agent), png)


def test_the_pixels_are_the_callers_written_into_its_array_or_a_new_one():
    """`Episode.frame_pixels` writes into the caller's `out` (an environment's observation
    slot) or returns a new array: either way the caller owns what it gets, and a later
    frame never changes it, though the simulator keeps the picture and its room."""
    import numpy as np

    config = load_task(SHARED_TASKS / f"{CONFIGS[0]}.json")
    episode = Episode(config)
    episode.reset()
    agent = config.agent_ids[0]
    first = episode.frame_pixels(agent)
    again = episode.frame_pixels(agent)
    slots = np.full((2, *first.shape), 7, np.uint8)
    slot = slots[1]
    written = episode.frame_pixels(agent, out=slot)
    assert written is slot and np.array_equal(written, first)
    assert (slots[0] == 7).all()  # only its slot is written
    assert not np.shares_memory(first, again) and first.flags.writeable
    kept = first.copy()
    first[:] = 0  # the caller's to change: the next frame is drawn as before
    assert np.array_equal(episode.frame_pixels(agent), kept)
    for call in list(oracle_plan(config))[:3]:
        episode.step(call)
    assert np.array_equal(again, kept)  # a later frame leaves an earlier one as it was


def test_a_controller_without_pixels_gives_its_png_decoded_into_the_callers_array():
    """A backend with no `frame_rgb` (AI2-THOR's) has its PNG decoded: into `out` when
    given, else into a new array the caller may write."""
    import io

    import numpy as np
    from PIL import Image

    config = load_task(SHARED_TASKS / f"{CONFIGS[0]}.json")
    episode = Episode(config)
    episode.reset()
    episode.controller.frame_rgb = None  # as a controller that gives no pixels
    agent = config.agent_ids[0]
    png = np.asarray(Image.open(io.BytesIO(episode.frame(agent))).convert("RGB"))
    fresh = episode.frame_pixels(agent)
    assert np.array_equal(fresh, png) and fresh.flags.writeable
    slots = np.zeros((2, *png.shape), np.uint8)
    slot = slots[0]
    assert episode.frame_pixels(agent, out=slot) is slot
    assert np.array_equal(slots[0], png) and not slots[1].any()
