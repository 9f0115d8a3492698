"""The fake server itself: its in-flight count must be exact, or the concurrency tests that
rely on it fail under load (issue 12, item 14)."""

from __future__ import annotations

import json
import time
import urllib.request

from .fake_openai import FakeOpenAI, ok


class SlowToRecount(FakeOpenAI):
    """A server whose handler thread is descheduled for a while when it lowers its count, as
    happens on a loaded machine."""

    def _done(self, generation: int) -> None:
        time.sleep(0.3)
        super()._done(generation)


def test_a_request_is_no_longer_in_flight_once_its_reply_arrives():
    with SlowToRecount(default=ok()) as server:
        request = urllib.request.Request(
            f"{server.base_url}/chat/completions", data=json.dumps({"model": "m"}).encode(),
            headers={"Content-Type": "application/json"})
        with urllib.request.urlopen(request, timeout=5) as response:
            assert response.status == 200
            # The client has its reply: its next request may start now, so this one must
            # not count any longer (it did, for 0.3 s, when the count came after the reply).
            assert server.in_flight == 0
