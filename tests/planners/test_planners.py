"""Planner graphs follow the reference's loop rules (reference §4.7, §5.5)."""

from __future__ import annotations

from dataclasses import dataclass, field

from benchmark_adapter.episode import Episode
from cocobench_agents.episode_runner import EpisodeSpec
from cocobench_agents.models import ModelError, ModelReply, ModelRequest

from .conftest import run


def menu_ids(config, agent: str | None = None) -> dict[str, int]:
    """call → id of the first observation's menu (inputs for scripts, not expectations)."""
    episode = Episode(config)
    obs = episode.reset()
    entries = obs.action_menu if agent is None else obs.menu_for(agent)
    return {e.call: e.action_id for e in entries}


def first_id(config, skill: str, agent: str = "agent_1") -> int:
    return next(i for call, i in menu_ids(config, agent).items()
                if call.startswith(f"{skill}({agent}"))


def steps(document) -> list[dict]:
    return [i for i in document["trajectory"] if "skill_result" in i]


def test_centralized_done_ends_the_episode_without_a_step(demo, script):
    config = demo["G_D1"]
    document, result = run(EpisodeSpec(config, models={"*": script(["ACTION: DONE"])}))
    assert steps(document) == []
    stop = document["trajectory"][-1]
    assert stop["label"] == "policy_stop"
    assert stop["policy_decision"]["terminal_reason"] == "done"
    assert result.failure_kind == "empty_plan"


def test_centralized_protocol_failures_end_the_episode_with_no_reprompt(demo, script):
    config = demo["G_D1"]
    for reply, reason in (("no idea", "parse_error"), ("ACTION: 99999", "invalid_action_id")):
        document, result = run(EpisodeSpec(config, models={"*": script([reply, "ACTION: 0"])}))
        assert steps(document) == []
        assert result.terminal_reason == reason
        assert (result.planner_steps, result.parse_errors) == (1, 1)
        assert result.failure_kind == "protocol_failure"


def test_bare_integer_fallback_takes_the_first_integer(demo, script):
    config = demo["G_D1"]
    explore = first_id(config, "Explore")
    reply = f"REASON: step {explore} looks fine"
    document, _ = run(EpisodeSpec(config, models={"*": script([reply, "ACTION: DONE"])}))
    assert len(steps(document)) == 1
    decision = steps(document)[0]["policy_decision"]
    assert decision["parse_mode"] == "bare_integer"
    assert decision["parsed_action_id"] == str(explore)


@dataclass
class FailingClient:
    name: str = "broken"
    accepts_images: bool = False

    async def complete(self, request: ModelRequest) -> ModelReply:
        raise ModelError("transient", "HTTP 500 from the server", retries=2)


@dataclass
class FixedPool:
    clients: dict = field(default_factory=dict)

    def client(self, spec, *, episode, agent):
        return self.clients.get(agent, self.clients.get("*"))

    def release(self, episode):
        pass


def test_a_backend_error_ends_a_centralized_episode(demo):
    document, result = run(EpisodeSpec(demo["G_D1"]), FixedPool({"*": FailingClient()}))
    assert result.terminal_reason == "backend_error"
    assert result.backend_errors == 1
    decision = document["planner_decisions"][0]
    assert decision["error_kind"] == "transient" and decision["retries"] == 2


def test_decentralized_round_lands_in_agent_order_and_stops_when_all_idle(demo, script):
    config = demo["G_D1"]
    find_1 = first_id(config, "Find", "agent_1")
    find_2 = first_id(config, "Find", "agent_2")
    models = {"*": "greedy", "agent_1": script([f"ACTION: {find_1}"]),
              "agent_2": script([f"ACTION: {find_2}", "no idea"])}
    document, result = run(EpisodeSpec(config, planner="decentralized", models=models))
    landed = steps(document)
    assert [s["skill_result"]["agent"] for s in landed] == ["agent_1", "agent_2"]
    assert [s["round_index"] for s in landed] == [1, 1]
    # Round 2: agent_1's script is used up (DONE), agent_2 cannot be parsed: nobody acts,
    # and the last agent's decision is the stop, as in the reference.
    assert result.terminal_reason == "parse_error"
    assert len(document["planner_decisions"]) == 4


def test_one_failing_agent_idles_while_its_teammate_acts(demo, script):
    config = demo["G_D1"]
    explore = first_id(config, "Explore", "agent_2")
    pool = FixedPool({"agent_1": FailingClient()})
    from cocobench_agents.models import ModelPool

    scripted = ModelPool().client(script([f"ACTION: {explore}"]), episode="e", agent="agent_2")
    pool.clients["agent_2"] = scripted
    pool.clients["*"] = scripted
    document, _ = run(EpisodeSpec(config, planner="decentralized"), pool)
    assert [s["skill_result"]["agent"] for s in steps(document)] == ["agent_2"]
    statuses = [d["status"] for d in document["planner_decisions"][:2]]
    assert statuses == ["backend_error", "action"]


def test_the_budget_cuts_a_round_short(demo, script):
    config = demo["G_D1"]
    models = {"*": "greedy"}
    document, result = run(EpisodeSpec(config, planner="decentralized", models=models,
                                       max_steps=3))
    assert len(steps(document)) == 3
    assert steps(document)[-1]["round_index"] == 2  # round 2 landed one of its two calls
    assert result.terminal_reason == "max_steps"


def test_broadcast_messages_reach_teammates_next_round(demo):
    config = demo["G_D1"]
    pool = MessagePool()
    run(EpisodeSpec(config, planner="decentralized-broadcast", max_steps=4), pool)
    first_round, second_round = pool.requests[:2], pool.requests[2:4]
    assert all("(no messages yet)" in r.prompt for r in first_round)
    by_agent = {r.agent: r.prompt for r in second_round}
    assert "  agent_2: I am agent_2" in by_agent["agent_1"]
    assert "  agent_1: I am agent_1" not in by_agent["agent_1"]  # one's own words are hidden
    assert "  agent_1: I am agent_1" in by_agent["agent_2"]


@dataclass
class MessageClient:
    agent: str | None
    log: list
    name: str = "talker"
    accepts_images: bool = False

    async def complete(self, request: ModelRequest) -> ModelReply:
        self.log.append(request)
        explore = next(o for o in request.menu if o.skill == "Explore")
        return ModelReply(f"REASON: x\nACTION: {explore.action_id}\nMSG: I am {self.agent}")


class MessagePool:
    def __init__(self):
        self.requests = []

    def client(self, spec, *, episode, agent):
        return MessageClient(agent, self.requests)

    def release(self, episode):
        pass


def test_stable_ids_keep_a_call_on_one_id(demo):
    pool = MessagePool()
    run(EpisodeSpec(demo["K_D3"], planner="centralized", max_steps=3, stable_ids=True), pool)
    menus = [{o.call: o.action_id for o in r.menu} for r in pool.requests]
    assert min(menus[0].values()) == 1
    shared = set(menus[0]) & set(menus[-1])
    assert shared and all(menus[0][c] == menus[-1][c] for c in shared)


def test_heterogeneous_teams_record_each_agent_model(demo):
    models = {"*": "greedy", "agent_2": "random:3"}
    document, result = run(EpisodeSpec(demo["G_D1"], planner="decentralized", models=models,
                                       max_steps=4))
    by_agent = {d["agent"]: d["model"] for d in document["planner_decisions"]}
    assert by_agent == {"agent_1": "greedy", "agent_2": "random:3"}
    assert result.models == {"agent_1": "greedy", "agent_2": "random:3"}


def test_prompt_variants_drop_their_section(demo):
    for variant, text in (("no-hint", "RELAY CONSTRAINT"), ("no-progress", "GOAL PROGRESS"),
                          ("no-history", "RECENT ACTIONS")):
        base, ablated = MessagePool(), MessagePool()
        run(EpisodeSpec(demo["J_D4"], max_steps=1), base)
        run(EpisodeSpec(demo["J_D4"], max_steps=1, prompt_suite=f"cocobench-v1+{variant}"),
            ablated)
        assert text in base.requests[0].prompt
        assert text not in ablated.requests[0].prompt


def test_the_oracle_planner_goes_through_the_same_run_path(demo):
    for config in demo.values():
        document, result = run(EpisodeSpec(config, planner="oracle", obs_mode="blind"))
        assert result.task_success == 1 and result.legal_plan == 1
        assert document["trajectory"][-1]["policy_decision"]["policy"] == "oracle"


def test_decision_counters_are_cumulative(demo, script):
    config = demo["G_D1"]
    explore = first_id(config, "Explore")
    replies = [f"ACTION: {explore}", "ACTION: 99999"]
    document, _ = run(EpisodeSpec(config, models={"*": script(replies)}))
    counters = [(d["planner_steps"], d["parse_errors"]) for d in document["planner_decisions"]]
    assert counters == [(1, 0), (2, 1)]
