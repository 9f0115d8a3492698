"""A resumed run replays a person's answers from the run folder's answer log, which may be
someone else's, damaged or forged: whatever its lines hold, a decision gets an answer it
accepts (replayed, or asked of the person again), never an exception (which a model call
would record as the seat's model failing). A log that cannot be read at all stops the run:
tests/human/test_human_seats.py."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cocobench_agents.harness.human_log import LoggedDesk, answers_file
from cocobench_agents.models.human import Answer, Decision
from cocobench_agents.runfolder.folder import RunFolder
from cocobench_agents.tools import prompt_hash

DECISION = Decision(id="human/C0_blind/T#team#1", episode="human/C0_blind/T", seat="team",
                    prompt="the prompt", menu=({"id": 3, "skill": "Wait", "call": "W()"},))
ASKED = Answer(3, reason="asked again", message="", think_s=1.0)

json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=8),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=4), inner,
                                                               max_size=3),
    max_leaves=6)
#: A line naming the decision with the right prompt's hash (so it is read as its answer),
#: each field missing or of any JSON value.
forged = st.fixed_dictionaries(
    {"decision": st.just(DECISION.id), "prompt_hash": st.just(prompt_hash(DECISION.prompt))},
    optional={field: json_values | st.just(3) for field in
              ("action_id", "reason", "message", "think_s", "call", "seat")})
lines = st.one_of(forged.map(json.dumps), json_values.map(json.dumps),
                  st.text(max_size=20))


class Person:
    async def ask(self, decision: Decision) -> Answer:
        return ASKED


@settings(max_examples=300, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(log=st.lists(lines, max_size=4), torn=st.booleans())
def test_any_answer_log_gives_an_answer_the_decision_accepts(tmp_path: Path, log, torn):
    path = tmp_path / answers_file(DECISION.episode)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(log) + ("" if torn or not log else "\n"), encoding="utf-8",
                    errors="surrogatepass")
    answer = asyncio.run(LoggedDesk(Person(), RunFolder(tmp_path)).ask(DECISION))
    assert DECISION.accepts(answer.action_id)
    assert isinstance(answer.reason, str) and isinstance(answer.message, str)
    assert isinstance(answer.think_s, float)
