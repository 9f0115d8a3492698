"""`planners --check` checks what a server would refuse (issue 36, item 5): the check's model
validates every request a strategy sends (message roles, content parts, image parts) against
the OpenAI chat schema, although greedy never reads it; so a request a real server answers
with HTTP 400 fails the check, naming the problem and the strategy's line that sent it."""

from __future__ import annotations

import base64
import textwrap

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cocobench_agents.cli import main
from cocobench_agents.models.chat_schema import messages_problem, request_problem
from cocobench_agents.models.messages import build_messages
from cocobench_agents.models.protocol import ModelRequest
from tests.planners.test_strategy_authoring import line_of

pytestmark = pytest.mark.usefixtures("fresh_planners")

PNG = b"\x89PNG\r\n\x1a\n" + bytes(16)
STRATEGY = textwrap.dedent('''
    from langgraph.graph import END, START, StateGraph
    from langgraph.runtime import Runtime

    from cocobench_agents.graphs import (PlannerContext, PlannerState, continue_or_end,
                                         decide, observe_next)
    from cocobench_agents.models import ModelRequest

    REQUEST = {request}


    async def price(state: PlannerState, runtime: Runtime[PlannerContext]) -> dict:
        """Ask the team's model for a price (the client directly), then step."""
        ctx = runtime.context
        await ctx.client_for(None).complete(ModelRequest(**REQUEST))
        decision = ctx.tools.record(await decide(ctx, None, policy="priced", history=[]))
        if not decision["parsed_call"]:
            ctx.tools.stop(decision)
            return {{"terminal_reason": decision["terminal_reason"]}}
        ctx.tools.land(decision["parsed_call"], decision=decision)
        return observe_next(ctx, state)


    def build_priced() -> StateGraph:
        graph = StateGraph(PlannerState, context_schema=PlannerContext)
        graph.add_node("price", price)
        graph.add_edge(START, "price")
        graph.add_conditional_edges("price", continue_or_end("price"), ["price", END])
        return graph
''')


@pytest.mark.parametrize(("request_text", "problem"), [
    ('{"prompt": "price?", "images": ("frame.png",)}',
     "images[0] is a str, not PNG bytes"),
    ('{"prompt": "price?", "images": (b"GIF89a....",)}',
     "messages[0].content[1].image_url.url: its bytes are not a PNG image"),
])
def test_check_fails_a_request_a_server_refuses_naming_the_line(tmp_path, capsys,
                                                                request_text, problem):
    strategy = tmp_path / "priced.py"
    strategy.write_text(STRATEGY.format(request=request_text))
    ref = f"{strategy}:build_priced"
    assert main(["planners", ref, "--check"]) == 1
    sent = line_of(strategy, "await ctx.client_for(None).complete")
    assert (f"cocobench: check failed: planner {ref}: its check episode "
            "(G_D1__DemoLivingRoom1__seed0, greedy) sent a request an OpenAI-compatible "
            f"server refuses (HTTP 400): {problem} (sent from {strategy}, line {sent})"
            ) in capsys.readouterr().err


def test_check_passes_a_well_formed_request(tmp_path, capsys):
    strategy = tmp_path / "priced.py"
    strategy.write_text(STRATEGY.format(request='{"prompt": "price?"}'))
    assert main(["planners", f"{strategy}:build_priced", "--check"]) == 0


def test_a_prompt_of_content_parts_is_recorded_then_judged_as_a_server_would(tmp_path, capsys):
    """A client used directly with a prompt of content parts: the call recorder keeps it
    (hashed over its JSON) and the schema check judges it, taking chat parts, refusing
    another API's part with the strategy's line."""
    strategy = tmp_path / "priced.py"
    strategy.write_text(STRATEGY.format(
        request='{"prompt": [{"type": "text", "text": "price?"}]}'))
    assert main(["planners", f"{strategy}:build_priced", "--check"]) == 0
    strategy = tmp_path / "priced_otherwise.py"  # a file of its own: one path loads once
    strategy.write_text(STRATEGY.format(
        request='{"prompt": [{"type": "input_text", "text": "price?"}]}'))
    assert main(["planners", f"{strategy}:build_priced", "--check"]) == 1
    sent = line_of(strategy, "await ctx.client_for(None).complete")
    err = capsys.readouterr().err
    assert "messages[0].content[0]: Input tag 'input_text'" in err
    assert f"(sent from {strategy}, line {sent})" in err
    assert "Traceback" not in err


def test_what_the_remote_clients_send_passes_the_schema():
    assert request_problem(ModelRequest("decide", images=(PNG, PNG))) is None
    assert request_problem(ModelRequest("decide")) is None


def test_content_parts_of_another_api_are_refused():
    assert request_problem(ModelRequest([{"type": "input_text", "text": "price?"}])) == (
        "messages[0].content[0]: Input tag 'input_text' found using 'type' does not match any "
        "of the expected tags: 'text', 'image_url'")


@pytest.mark.parametrize(("messages", "problem"), [
    ([{"role": "robot", "content": "x"}], "messages[0]: Input tag 'robot'"),
    ([{"role": "user", "content": [{"type": "image_url", "image_url": "data:,"}]}],
     "messages[0].content[0].image_url: Input should be a valid dictionary"),
    ([{"role": "user", "content": [{"type": "image_url", "image_url": {
        "url": "data:image/bmp;base64,AAAA"}}]}],
     "messages[0].content[0].image_url.url: image/bmp is not one of image/png"),
    ([{"role": "user", "content": [{"type": "image_url", "image_url": {
        "url": "data:image/png;base64,not base64!"}}]}],
     "messages[0].content[0].image_url.url: its base64 does not decode"),
    ([{"role": "user", "content": []}], "messages[0].content: List should have at least 1"),
    ([{"role": "system", "content": [{"type": "image_url", "image_url": {
        "url": "https://example.org/a.png"}}]}], "messages[0].content[0]"),
    ([], "messages: List should have at least 1 item"),
])
def test_a_malformed_message_is_named(messages, problem):
    assert messages_problem(messages).startswith(problem)


def test_an_image_by_url_or_of_each_format_passes():
    jpeg = "data:image/jpeg;base64," + base64.b64encode(b"\xff\xd8\xff\xe0").decode()
    for url in ("https://example.org/a.png", jpeg):
        assert messages_problem([{"role": "user", "content": [
            {"type": "text", "text": "look"},
            {"type": "image_url", "image_url": {"url": url, "detail": "low"}}]}]) is None


json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.text(max_size=12) | st.binary(max_size=12),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(
        st.sampled_from(["role", "content", "type", "text", "image_url", "url", "detail",
                         "x"]), inner, max_size=4), max_leaves=16)


@settings(max_examples=300, deadline=None)
@given(st.one_of(json_values, st.text()), st.lists(st.one_of(st.binary(max_size=20),
                                                             st.text(max_size=5)), max_size=2))
def test_any_request_a_stranger_builds_is_judged_without_raising(prompt, images):
    problem = request_problem(ModelRequest(prompt, images=tuple(images)))
    assert problem is None or (isinstance(problem, str) and problem)
    if problem is None:  # then a remote client can build it, as the check did
        build_messages(ModelRequest(prompt, images=tuple(images)))
