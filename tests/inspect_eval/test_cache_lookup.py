"""Whether Inspect served a reply from its cache is read from the model events the call
logged (from the transcript's event count before it on), in a real transcript."""

from __future__ import annotations

import contextvars

import pytest

from cocobench_agents.models.inspect_client import served_from_cache

pytestmark = pytest.mark.needs_inspect


def _log(transcript, output, cache: str) -> None:
    from inspect_ai.event import ModelEvent
    from inspect_ai.model import GenerateConfig

    transcript._event(ModelEvent(model="m", input=[], tools=[], tool_choice="none",
                                 config=GenerateConfig(), output=output, cache=cache))


def _lookups() -> list[bool]:
    from inspect_ai.log._transcript import Transcript, init_transcript
    from inspect_ai.model import ModelOutput

    transcript = Transcript()
    init_transcript(transcript)  # in this test's own context (see the caller)
    earlier = ModelOutput.from_content("m", "ACTION: 1")
    for _ in range(500):  # a long sample's history, read before this call
        _log(transcript, ModelOutput.from_content("m", "ACTION: 2"), "write")
    _log(transcript, earlier, "read")
    since = transcript.history.event_count
    now = ModelOutput.from_content("m", "ACTION: 1")  # equal to `earlier`, not the same
    _log(transcript, now, "write")
    return [served_from_cache(now, since), served_from_cache(earlier, 0),
            served_from_cache(earlier, since + 1), served_from_cache(now.model_copy(), since)]


def test_the_calls_own_event_says_whether_it_was_read_from_the_cache() -> None:
    # a context of its own: the transcript set here never leaks into another test
    assert contextvars.copy_context().run(_lookups) == [False, True, False, False]
