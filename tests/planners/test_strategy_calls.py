"""A strategy's own model calls (`ask`, and a client used directly) are recorded and counted
as decisions: usage, tokens and cost equal what a counting OpenAI-compatible server received
(examples/strategies/sealed_bid.py: a second, pricing call for contested objects)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from benchmark_adapter.metrics.usage import model_usage
from benchmark_adapter.trajectory import PROMPTS_FIELD
from cocobench_agents.episode_runner import EpisodeSpec
from cocobench_agents.models import ModelPool, ModelSettings
from cocobench_agents.models.openai_http import token_prices
from tests.models.fake_openai import SERVER_ERROR, Behaviour, FakeOpenAI, completion_body

from .conftest import run

ROOT = Path(__file__).resolve().parents[2]
SEALED_BID = f"{ROOT / 'examples' / 'strategies' / 'sealed_bid.py'}:SEALED_BID"
DIRECT = f"{Path(__file__).with_name('direct_call_planner.py')}:DIRECT"
PRICED = "openai/gpt-4o-mini"  # priced in the cost map LiteLLM ships
FIND_BOOK = {"agent_1": "ACTION: 0", "agent_2": "ACTION: 24"}  # G_D1's first menu (blind)


def reply(text: str, prompt_tokens: int, completion_tokens: int) -> Behaviour:
    return Behaviour(200, completion_body(text, prompt_tokens=prompt_tokens,
                                          completion_tokens=completion_tokens))


@pytest.fixture(scope="module")
def server():
    with FakeOpenAI() as fake:
        yield fake


def settings(server: FakeOpenAI, **overrides) -> ModelSettings:
    return ModelSettings(api_base=server.base_url, backoff_s=0.001, backoff_max_s=0.002,
                         **overrides)


def test_a_pricing_call_is_counted_as_the_server_received_it(server, demo, fresh_planners):
    """Round 1: both robots bid for the Book (2 calls), both are asked their price (2 more:
    agent_2 is cheaper and gets it); round 2: both say DONE (2 calls). Six requests, each
    with its own token counts: usage, tokens and cost are theirs exactly."""
    script = [reply(FIND_BOOK["agent_1"], 101, 5), reply(FIND_BOOK["agent_2"], 102, 6),
              reply("ACTION: 4", 53, 3), reply("ACTION: 2", 54, 4),
              reply("ACTION: DONE", 105, 2), reply("ACTION: DONE", 106, 1)]
    server.program(*script, default=reply("ACTION: DONE", 1, 1))
    spec = EpisodeSpec(demo["G_D1"], planner=SEALED_BID, models={"*": PRICED},
                       obs_mode="blind", max_steps=6)
    document, result = run(spec, ModelPool(settings(server)))

    usage = model_usage(document)
    assert server.count == usage.model_calls == 6 == result.usage.model_calls
    assert usage.prompt_tokens == 101 + 102 + 53 + 54 + 105 + 106
    assert usage.completion_tokens == 5 + 6 + 3 + 4 + 2 + 1
    price_in, price_out = token_prices(PRICED)
    assert price_in > 0
    assert usage.cost_usd == round(usage.prompt_tokens * price_in
                                   + usage.completion_tokens * price_out, 6)

    asks = [d for d in document["planner_decisions"] if d.get("ask")]
    assert [(d["agent"], d["ask"], d["answer"], d["status"]) for d in asks] == [
        ("agent_1", "pricing", "4", "action"), ("agent_2", "pricing", "2", "action")]
    sent = [r["messages"][0]["content"] for r in server.requests[2:4]]
    assert [document[PROMPTS_FIELD][d["prompt_hash"]] for d in asks] == [
        c if isinstance(c, str) else c[0]["text"] for c in sent]
    assert "Teammates also want to work on the Book" in document[PROMPTS_FIELD][
        asks[0]["prompt_hash"]]
    landed = [i for i in document["trajectory"] if "skill_result" in i]
    assert [i["label"] for i in landed] == ["Find(agent_2, Book|+01.20|+00.55|-00.80)"]
    outbid = next(d for d in document["planner_decisions"] if d["status"] == "outbid")
    assert (outbid["agent"], outbid["outbid_by"], outbid["price"]) == ("agent_1", "agent_2", 4)


def test_a_failing_pricing_call_is_retried_and_counted(server, demo, fresh_planners):
    """The run's retry policy applies to `ask`: a 500 then an answer is one recorded call
    with one retry, its tokens those of the answer."""
    server.program(reply(FIND_BOOK["agent_1"], 10, 1), reply(FIND_BOOK["agent_2"], 10, 1),
                   SERVER_ERROR, reply("ACTION: 1", 20, 2), reply("ACTION: 5", 20, 2),
                   default=reply("ACTION: DONE", 1, 1))
    spec = EpisodeSpec(demo["G_D1"], planner=SEALED_BID, models={"*": PRICED},
                       obs_mode="blind", max_steps=6)
    document, _ = run(spec, ModelPool(settings(server)))
    first = next(d for d in document["planner_decisions"] if d.get("ask"))
    assert (first["answer"], first["retries"], first["prompt_tokens"]) == ("1", 1, 20)
    usage = model_usage(document)
    assert usage.retries == 1 and usage.model_calls == server.count - 1  # one call, 2 tries


def test_a_call_made_with_the_client_directly_is_counted_all_the_same(server, demo,
                                                                      fresh_planners):
    """A strategy that asks the context's client itself, through the retry policy: each
    attempt the server received is a recorded call (a failed one as ``direct_error``)."""
    server.program(SERVER_ERROR, reply("be quick", 7, 3), reply(FIND_BOOK["agent_1"], 11, 1),
                   reply(FIND_BOOK["agent_2"], 12, 1), default=reply("ACTION: DONE", 2, 1))
    spec = EpisodeSpec(demo["G_D1"], planner=DIRECT, models={"*": PRICED}, obs_mode="blind",
                       max_steps=4)
    document, _ = run(spec, ModelPool(settings(server)))
    usage = model_usage(document)
    assert usage.model_calls == server.count
    decisions = document["planner_decisions"]
    assert [d["status"] for d in decisions[:2]] == ["direct_error", "direct"]
    assert decisions[1]["raw_output"] == "be quick"
    assert document[PROMPTS_FIELD][decisions[1]["prompt_hash"]] == "Round 1: any advice?"
    assert usage.backend_errors == 0  # the strategy's retry got its answer
    assert usage.prompt_tokens == 7 + 11 + 12 + 2 * (server.count - 4)  # then 1 each


def test_a_built_in_model_answers_an_ask_from_its_menu(demo, script, fresh_planners):
    """Offline models choose among the ask's menu: scripted replies name a price."""
    model = script({"agent_1": [FIND_BOOK["agent_1"], "ACTION: 2", "ACTION: DONE"],
                    "agent_2": [FIND_BOOK["agent_2"], "ACTION: 3", "ACTION: DONE"]})
    document, result = run(EpisodeSpec(demo["G_D1"], planner=SEALED_BID, models={"*": model},
                                       obs_mode="blind"))
    landed = [i["label"] for i in document["trajectory"] if "skill_result" in i]
    assert landed == ["Find(agent_1, Book|+01.20|+00.55|-00.80)"]
    assert result.usage.model_calls == 6


def test_an_answer_off_the_menu_is_a_parse_error_counted_as_one(demo, script,
                                                                fresh_planners):
    model = script({"agent_1": [FIND_BOOK["agent_1"], "ACTION: 9", "ACTION: DONE"],
                    "agent_2": [FIND_BOOK["agent_2"], "no idea", "ACTION: DONE"]})
    document, _ = run(EpisodeSpec(demo["G_D1"], planner=SEALED_BID, models={"*": model},
                                  obs_mode="blind"))
    asks = [d for d in document["planner_decisions"] if d.get("ask")]
    assert [(d["status"], d["answer"]) for d in asks] == [
        ("invalid_action_id", None), ("parse_error", None)]
    assert model_usage(document).parse_errors == 2


def test_the_dry_run_counts_the_pricing_prompt_of_every_seat(demo, fresh_planners):
    """Per episode: every robot's decision prompt and its pricing prompt (the strategy's
    fields shown as `{object}`, `{wanted}`, `{menu}`); the calls bounded by 2 per robot per
    round."""
    from cocobench_agents.engine.estimate import estimate
    from cocobench_agents.engine.first_prompts import first_round_requests
    from cocobench_agents.harness import Condition, plan_episodes
    from cocobench_agents.models import import_litellm

    config = demo["G_D1"]
    (planned,) = plan_episodes([config], [PRICED], [Condition(SEALED_BID, "blind")], 1,
                               max_steps=5)
    requests = first_round_requests(planned.spec)
    assert [(r.agent, r.template) for r in requests] == [
        ("agent_1", None), ("agent_2", None), ("agent_1", "pricing"), ("agent_2", "pricing")]
    pricing = requests[2].messages[0]["content"]
    assert "You are agent_1" in pricing and "the {object} this round" in pricing
    assert "{menu}" in pricing and "{me}" not in pricing

    plan = estimate([planned], ModelSettings())
    count = import_litellm().token_counter
    tokens = [count(model=PRICED, messages=r.messages) for r in requests]
    assert plan.episodes[0].prompt_tokens == sum(tokens) > sum(tokens[:2])
    assert plan.rows[0].max_calls == 2 * config.agent_count * 5


@pytest.mark.slow
def test_the_summary_and_the_reports_cost_table_count_every_call(server, tmp_path, capsys,
                                                                  fresh_planners):
    """A whole run (`cocobench run`, then `cocobench report`): the report's planner calls,
    tokens and cost totals are what the server received and billed."""
    import csv

    from cocobench_agents.cli import main

    server.program(reply(FIND_BOOK["agent_1"], 101, 5), reply(FIND_BOOK["agent_2"], 102, 6),
                   reply("ACTION: 4", 53, 3), reply("ACTION: 2", 54, 4),
                   default=reply("ACTION: DONE", 9, 1))
    out = tmp_path / "run"
    code = main(["run", "--planner", SEALED_BID, "--model", PRICED, "--api-base",
                 server.base_url, "--suite", "demo", "--task-id", "G_D1__DemoLivingRoom1__seed0",
                 "--obs", "blind", "--max-steps", "6", "--no-preflight", "--out", str(out)])
    assert code == 0, capsys.readouterr().err
    assert main(["report", str(out), "--out", str(tmp_path / "report")]) == 0
    (row,) = csv.DictReader((tmp_path / "report" / "cost.csv").open())
    price_in, price_out = token_prices(PRICED)
    prompt_tokens = 101 + 102 + 53 + 54 + 9 * (server.count - 4)
    completion_tokens = 5 + 6 + 3 + 4 + (server.count - 4)
    assert int(float(row["planner_calls_total"])) == server.count == 6
    assert int(float(row["prompt_tokens_total"])) == prompt_tokens
    cost = prompt_tokens * price_in + completion_tokens * price_out
    assert float(row["cost_usd_total"]) == pytest.approx(cost, abs=5e-7)  # the CSV's digits
    (line,) = [json.loads(x) for x in (out / "results.jsonl").read_text().splitlines()]
    assert line["usage"]["cost_usd"] == round(cost, 6)
