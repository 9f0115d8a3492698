"""The dry-run estimate (`engine.estimate`): episodes, the model calls the step budgets allow,
each episode's first-prompt tokens and a cost range, per model × condition × arm. Offline,
with the real planners, prompts, simulator and LiteLLM; expectations are computed here from
the configs and from prompts rendered the way `cocobench prompts show` renders them."""

from __future__ import annotations

import json
import textwrap
import time
from pathlib import Path

import pytest

from benchmark_adapter.episode import Episode
from benchmark_adapter.oracles import oracle_plan
from benchmark_adapter.tasks import TaskConfig, load_tasks
from cocobench_agents.engine.costs import CostPlan
from cocobench_agents.engine.estimate import estimate
from cocobench_agents.engine.first_prompts import first_round_requests
from cocobench_agents.harness import (
    Condition,
    ExecutionSettings,
    InProcess,
    parse_conditions,
    plan_episodes,
)
from cocobench_agents.harness.episodes import planner_conditions, suite_arms
from cocobench_agents.models import (
    ModelPool,
    ModelRequest,
    ModelSettings,
    build_messages,
    import_litellm,
)
from cocobench_agents.prompts import DEFAULT_SUITE, load_prompt_suite
from cocobench_agents.runfolder import RunFolder
from cocobench_agents.tools import EpisodeTools
from tests.models.fake_openai import FakeOpenAI, ok

DEMO = load_tasks("demo")  # 4 instances: one of 3 agents, three of 2; budgets 34, 20, 60, 24
G_D1 = next(c for c in DEMO if c.cell == "G_D1")
THREE_AGENTS = next(c for c in DEMO if c.agent_count == 3)
USER_PLANNER = str(Path(__file__).parents[1] / "planners" / "user_planner.py") + ":ONE_NODE"
FIRST_COME = str(Path(__file__).parents[2] / "examples" / "strategies" / "first_come.py"
                 ) + ":FIRST_COME"
PRICED = "gpt-4o-mini"  # priced in the cost map LiteLLM ships
UNPRICED = "openai/my-local-model"
C0_IMAGE, C0_BLIND = Condition("centralized", "image"), Condition("centralized", "blind")
D0_IMAGE = Condition("decentralized", "image")
D1_BLIND = Condition("decentralized-broadcast", "blind")
LW_BLIND = Condition("leader-worker", "blind")
ORACLE = Condition("oracle", "image")


def plan(models: list[str], conditions: list[Condition], tasks: list[TaskConfig] = DEMO,
         **options) -> list:
    return plan_episodes(list(tasks), models, conditions, 1, **options)


def first_prompt(config: TaskConfig, *, agent: str | None = None, obs: str = "image",
                 broadcast: bool = False, images: bool = True) -> list[dict]:
    """The messages of one first-step prompt, rendered as `cocobench prompts show` does (a
    fresh episode, `EpisodeTools.prompt`), with the frame when `images`."""
    tools = EpisodeTools(Episode(config), load_prompt_suite(DEFAULT_SUITE), obs_mode=obs)
    tools.start()
    text, frames, _ = tools.prompt(agent, [], broadcast=broadcast, with_images=images)
    return build_messages(ModelRequest(prompt=text, images=frames))


def count(model: str, messages: list[dict]) -> int:
    return import_litellm().token_counter(model=model, messages=messages)


def price(model: str, kind: str) -> float:
    return import_litellm().model_cost[model][f"{kind}_cost_per_token"]


def row(result: CostPlan, condition: str, model: str | None = None):
    (found,) = [r for r in result.rows
                if r.condition == condition and model in (None, r.model)]
    return found


# -- calls and built-in models ------------------------------------------------------------

def test_built_in_models_are_free_and_their_calls_are_bounded_by_the_step_budgets():
    conditions = [*parse_conditions("all"), LW_BLIND, ORACLE]
    result = estimate(plan(["greedy"], conditions), ModelSettings())
    budgets = [(c.difficulty.step_budget, c.agent_count) for c in DEMO]
    calls_per_step = {"C0": lambda n: 1, "D0": lambda n: n, "D1": lambda n: n,
                      "LW": lambda n: n + 1, "OR": lambda n: 0}
    assert [r.condition for r in result.rows] == [c.name for c in conditions]  # plan order
    for r in result.rows:
        per_step = calls_per_step[r.condition.split("_")[0]]
        assert r.max_calls == sum(b * per_step(n) for b, n in budgets), r.condition
        assert r.episodes == len(DEMO)
        assert (r.cost_usd.low, r.cost_usd.high) == (0.0, 0.0)
        assert r.model == ("oracle" if r.condition == "OR_image" else "greedy")
    oracle = row(result, "OR_image")
    assert oracle.prompt_tokens == 0 and oracle.models == ()
    assert all(r.prompt_tokens > 0 for r in result.rows if r is not oracle)
    assert result.total.max_calls == sum(r.max_calls for r in result.rows)
    assert (result.total.cost_usd.low, result.total.cost_usd.high) == (0.0, 0.0)
    assert set(result.token_counters) == {"greedy"}


def test_max_steps_replaces_every_budget():
    result = estimate(plan(["random:3"], [C0_BLIND, D0_IMAGE], max_steps=3), ModelSettings())
    assert row(result, "C0_blind").max_calls == 3 * len(DEMO)
    assert row(result, "D0_image").max_calls == 3 * sum(c.agent_count for c in DEMO)


def test_a_built_in_model_is_counted_on_the_text_it_gets_without_frames():
    result = estimate(plan(["greedy"], [C0_IMAGE], [G_D1]), ModelSettings())
    # No model string: LiteLLM's default counter; built-ins read no frames.
    assert row(result, "C0_image").prompt_tokens == import_litellm().token_counter(
        messages=first_prompt(G_D1, images=False))


def test_a_planner_of_the_users_own_is_bounded_by_agents_times_budget_and_marked():
    (condition,) = planner_conditions([USER_PLANNER], ["blind"])
    result = estimate(plan(["greedy"], [condition, C0_BLIND]), ModelSettings())
    mine, c0 = result.rows
    assert mine.assumed and not c0.assumed
    assert mine.max_calls == sum(c.difficulty.step_budget * c.agent_count for c in DEMO)
    assert mine.prompt_tokens == c0.prompt_tokens  # asked as C0 asks: the team's prompt


def test_a_broadcasting_plugin_is_counted_as_d1_for_the_same_prompts():
    # examples/strategies/first_come.py declares loop="round", prompt="agent", broadcast=True
    (mine,) = planner_conditions([FIRST_COME], ["blind"])
    result = estimate(plan([PRICED], [mine, D1_BLIND]), ModelSettings())
    first_come, d1 = result.rows
    assert first_come.prompt_tokens == d1.prompt_tokens  # the board counted, as D1's
    assert (first_come.max_calls, first_come.assumed) == (d1.max_calls, False)


def test_a_spec_without_a_loop_keeps_the_assumed_bound_but_counts_its_board(tmp_path):
    # a strategy written before specs declared their loop: it broadcasts, nothing more
    source = Path(FIRST_COME.rpartition(":")[0]).read_text()
    undeclared = source.replace('    loop="round",', "    loop=None,")
    (tmp_path / "undeclared.py").write_text(undeclared)
    (mine,) = planner_conditions([f"{tmp_path / 'undeclared.py'}:FIRST_COME"], ["blind"])
    d0_blind = Condition("decentralized", "blind")
    result = estimate(plan([PRICED], [mine, D1_BLIND, d0_blind]), ModelSettings())
    first_come, d1, d0 = result.rows
    assert first_come.assumed and first_come.max_calls == d0.max_calls
    assert first_come.prompt_tokens == d1.prompt_tokens > d0.prompt_tokens


def test_a_step_loop_of_agent_prompts_counts_agent_1s_prompt_once_per_step(tmp_path):
    # the guide's round_robin, declared: one robot's own prompt per landed step
    fixture = Path(USER_PLANNER.rpartition(":")[0]).read_text()
    (tmp_path / "rr.py").write_text(fixture + textwrap.dedent("""
        ROUND_ROBIN = PlannerSpec("rr", "RR", build_one_node, True, True, "turns",
                                  loop="step", prompt="agent")
    """))
    (mine,) = planner_conditions([f"{tmp_path / 'rr.py'}:ROUND_ROBIN"], ["blind"])
    result = estimate(plan([PRICED], [mine], [G_D1]), ModelSettings())
    (rr,) = result.rows
    assert rr.prompt_tokens == count(PRICED, first_prompt(G_D1, agent="agent_1", obs="blind"))
    assert (rr.max_calls, rr.assumed) == (G_D1.difficulty.step_budget, False)


def test_the_first_round_is_the_requests_a_client_would_send_in_order():
    (planned,) = plan([PRICED], [Condition("decentralized-broadcast", "image")],
                      [THREE_AGENTS])
    requests = first_round_requests(planned.spec)
    assert [(r.role, r.agent, r.model) for r in requests] == [
        ("agent", a, PRICED) for a in THREE_AGENTS.agent_ids]
    for request in requests:
        assert request.messages == first_prompt(THREE_AGENTS, agent=request.agent,
                                                broadcast=True)
    (oracle,) = plan(["greedy"], [ORACLE], [THREE_AGENTS])
    assert first_round_requests(oracle.spec) == []


# -- a priced model --------------------------------------------------------------------------

def test_a_priced_model_counts_its_first_prompt_and_prices_a_range():
    result = estimate(plan([PRICED], [C0_IMAGE], [G_D1]), ModelSettings())
    r = row(result, "C0_image")
    tokens = count(PRICED, first_prompt(G_D1))
    assert r.prompt_tokens == tokens
    oracle_calls = sum(1 for _ in oracle_plan(G_D1))  # the released plans are open-loop
    assert r.cost_usd.low == pytest.approx(tokens * oracle_calls * price(PRICED, "input"))
    assert r.cost_usd.high == pytest.approx(
        G_D1.difficulty.step_budget * tokens * price(PRICED, "input"))
    assert 0 < r.cost_usd.low <= r.cost_usd.high
    assert "o200k_base" in result.token_counters[PRICED]


def test_max_tokens_adds_the_completion_bound_to_high_only():
    episodes = plan([PRICED], [D1_BLIND])
    without = estimate(episodes, ModelSettings())
    capped = estimate(episodes, ModelSettings(max_tokens=50))
    r, c = row(without, "D1_blind"), row(capped, "D1_blind")
    assert c.cost_usd.low == r.cost_usd.low
    assert c.cost_usd.high == pytest.approx(
        r.cost_usd.high + r.max_calls * 50 * price(PRICED, "output"))


def test_a_decentralized_first_round_is_every_agents_prompt():
    result = estimate(plan([PRICED], [D1_BLIND, LW_BLIND], [THREE_AGENTS]), ModelSettings())
    agents = [count(PRICED, first_prompt(THREE_AGENTS, agent=a, obs="blind", broadcast=True))
              for a in THREE_AGENTS.agent_ids]
    assert row(result, "D1_blind").prompt_tokens == sum(agents)
    # leader–worker: the leader's prompt as well (it asks first)
    assert row(result, "LW_blind").prompt_tokens > sum(agents)


def test_image_conditions_count_the_frame():
    result = estimate(plan([PRICED], [C0_IMAGE, C0_BLIND]), ModelSettings())
    image, blind = row(result, "C0_image"), row(result, "C0_blind")
    assert image.prompt_tokens > blind.prompt_tokens
    assert image.cost_usd.high > blind.cost_usd.high
    assert image.max_calls == blind.max_calls


# -- unknown prices and heterogeneous teams --------------------------------------------------

def test_a_model_without_a_price_has_an_unknown_cost_and_so_has_the_total():
    result = estimate(plan([UNPRICED, "greedy"], [C0_BLIND]), ModelSettings(),
                      max_cost_usd=1.0)
    unpriced, greedy = row(result, "C0_blind", UNPRICED), row(result, "C0_blind", "greedy")
    assert (unpriced.cost_usd.low, unpriced.cost_usd.high) == (None, None)
    assert unpriced.prompt_tokens > 0 and unpriced.max_calls == greedy.max_calls
    assert (greedy.cost_usd.low, greedy.cost_usd.high) == (0.0, 0.0)
    assert (result.total.cost_usd.low, result.total.cost_usd.high) == (None, None)
    assert result.low_exceeds_max_cost is None and result.high_exceeds_max_cost is None
    document = result.to_json()
    assert document["total"]["cost_usd"] == {"low": None, "high": None}
    assert "default" in result.token_counters[UNPRICED]


def test_agent_models_count_each_prompt_with_its_own_model_and_price():
    config = G_D1
    mixed = estimate(plan([PRICED], [D0_IMAGE], [config], agent_models={"agent_2": "greedy"}),
                     ModelSettings())
    r = row(mixed, "D0_image")
    assert r.model == PRICED and r.models == (PRICED, "greedy")
    agent_1, agent_2 = config.agent_ids
    assert r.prompt_tokens == (count(PRICED, first_prompt(config, agent=agent_1))
                               + import_litellm().token_counter(
                                   messages=first_prompt(config, agent=agent_2, images=False)))
    same = row(estimate(plan([PRICED], [D0_IMAGE], [config]), ModelSettings()), "D0_image")
    assert r.max_calls == same.max_calls
    assert 0 < r.cost_usd.high < same.cost_usd.high  # agent_2's calls are free
    assert set(mixed.token_counters) == {PRICED, "greedy"}

    unpriced = estimate(plan([PRICED], [D0_IMAGE], [config],
                             agent_models={"agent_2": UNPRICED}), ModelSettings())
    assert row(unpriced, "D0_image").cost_usd.high is None


# -- the JSON object and the spend limit -----------------------------------------------------

def test_to_json_is_exactly_the_documented_object():
    arms = suite_arms([load_prompt_suite(DEFAULT_SUITE),
                       load_prompt_suite(f"{DEFAULT_SUITE}+no-hint")])
    result = estimate(plan([PRICED], [C0_BLIND], arms=arms), ModelSettings(),
                      max_cost_usd=0.5)
    document = json.loads(json.dumps(result.to_json()))
    assert set(document) == {"rows", "total", "token_counters", "max_cost_usd", "episodes"}
    cost_keys = {"low", "high"}
    for r in document["rows"]:
        assert set(r) == {"model", "condition", "arm", "episodes", "max_calls",
                          "prompt_tokens", "cost_usd"}
        assert set(r["cost_usd"]) == cost_keys
    assert [r["arm"] for r in document["rows"]] == list(arms)
    assert set(document["total"]) == {"episodes", "max_calls", "prompt_tokens", "cost_usd"}
    assert set(document["total"]["cost_usd"]) == cost_keys
    assert document["total"]["episodes"] == 2 * len(DEMO)
    assert set(document["max_cost_usd"]) == {"limit", "low_exceeds", "high_exceeds"}
    # the no-hint arm drops the K and D4 hint lines
    hinted, plain = document["rows"]
    assert plain["prompt_tokens"] < hinted["prompt_tokens"]

    assert [(e["arm"], e["task_id"]) for e in document["episodes"]] == [
        (arm, c.task_id) for arm in arms for c in DEMO]
    for e in document["episodes"]:
        assert set(e) == {"model", "condition", "arm", "task_id", "epoch", "prompt_tokens"}

    single = estimate(plan(["greedy"], [C0_BLIND], [G_D1]), ModelSettings()).to_json()
    assert single["rows"][0]["arm"] is None and single["max_cost_usd"] is None
    assert single["episodes"][0]["arm"] is None


def test_every_episode_has_its_first_prompt_tokens_and_a_row_sums_them():
    conditions = [C0_BLIND, D1_BLIND, ORACLE]
    episodes = plan_episodes(list(DEMO), ["greedy"], conditions, 2)
    result = estimate(episodes, ModelSettings())
    assert len(result.episodes) == len(conditions) * len(DEMO) * 2
    for r in result.rows:
        mine = [e for e in result.episodes if (e.model, e.condition) == (r.model, r.condition)]
        assert len(mine) == r.episodes and sum(e.prompt_tokens for e in mine) == r.prompt_tokens
    by_episode = {(e.condition, e.task_id, e.epoch): e.prompt_tokens for e in result.episodes}
    team = import_litellm().token_counter(messages=first_prompt(G_D1, obs="blind",
                                                                images=False))
    assert by_episode["C0_blind", G_D1.task_id, 0] == by_episode["C0_blind", G_D1.task_id, 1]
    assert by_episode["C0_blind", G_D1.task_id, 1] == team  # the episode's own, not a share
    assert all(by_episode["OR_image", c.task_id, 0] == 0 for c in DEMO)
    assert by_episode["D1_blind", THREE_AGENTS.task_id, 0] > by_episode[
        "C0_blind", THREE_AGENTS.task_id, 0]  # three agents' prompts against one


def test_the_spend_limit_is_compared_with_both_bounds():
    episodes = plan([PRICED], [C0_BLIND])
    cost = estimate(episodes, ModelSettings()).total.cost_usd
    between = (cost.low + cost.high) / 2
    result = estimate(episodes, ModelSettings(), max_cost_usd=between)
    assert result.max_cost_usd == between
    assert (result.low_exceeds_max_cost, result.high_exceeds_max_cost) == (False, True)
    above = estimate(episodes, ModelSettings(), max_cost_usd=cost.high * 2)
    assert (above.low_exceeds_max_cost, above.high_exceeds_max_cost) == (False, False)
    below = estimate(episodes, ModelSettings(), max_cost_usd=cost.low / 2)
    assert (below.low_exceeds_max_cost, below.high_exceeds_max_cost) == (True, True)
    unlimited = estimate(episodes, ModelSettings())
    assert unlimited.low_exceeds_max_cost is None and unlimited.high_exceeds_max_cost is None


def test_a_tokenizer_litellm_would_download_is_not_fetched():
    """Offline, LiteLLM retries the Hugging Face Hub for about 25 s before falling back."""
    started = time.perf_counter()
    result = estimate(plan(["openai/llama-3-8b-instruct"], [C0_BLIND], [G_D1]),
                      ModelSettings())
    assert time.perf_counter() - started < 10
    assert "fetches nothing" in result.token_counters["openai/llama-3-8b-instruct"]
    assert row(result, "C0_blind").prompt_tokens > 0


# -- against a real run ----------------------------------------------------------------------

@pytest.mark.slow
@pytest.mark.parametrize(("condition", "stable_ids"), [
    (C0_IMAGE, False), (D1_BLIND, True), (Condition("leader-worker", "image"), False)])
def test_a_run_sends_the_estimated_first_round_and_no_more_calls(tmp_path, condition,
                                                                 stable_ids):
    model = "openai/test-model"
    with FakeOpenAI(default=ok("REASON: go\nACTION: 1")) as server:
        settings = ModelSettings(api_base=server.base_url)
        episodes = plan([model], [condition], DEMO[:3], max_steps=3, stable_ids=stable_ids)
        for i, planned in enumerate(episodes):
            server.program()
            (estimated,) = estimate([planned], settings).rows
            assert server.count == 0  # the estimate called no model
            folder = RunFolder(tmp_path / f"run{i}")
            folder.create({"name": "estimate"})
            InProcess().run([planned], folder, ModelPool(settings), ExecutionSettings(jobs=1))
            assert 0 < server.count <= estimated.max_calls
            agents = planned.spec.config.agent_count
            first_round = {"centralized": 1, "decentralized-broadcast": agents,
                           "leader-worker": agents + 1}[condition.planner]
            sent = sum(count(model, request["messages"])
                       for request in server.requests[:first_round])
            assert sent == estimated.prompt_tokens, planned.key.task_id
