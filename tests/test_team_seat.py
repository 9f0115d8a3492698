"""The team's seat has one name, `TEAM_SEAT` ("team"): the key of the team's client in a
planner's context, of its history in planner state, of its replies in a `scripted:` file, of
its decisions on a person's desk and in exported datasets, and of its seat in the
environments. No module spells it another way."""

from __future__ import annotations

import ast

from cocobench_agents.graphs import TEAM, PlannerContext
from cocobench_agents.graphs.registry import TEAM_SEAT as REGISTRY_TEAM
from cocobench_agents.models import ModelPool
from cocobench_agents.models.protocol import TEAM_SEAT
from tests.source import modules, nodes


def test_every_name_of_the_team_is_the_one_constant():
    from cocobench_agents.export.decisions import CENTRALIZED_SEAT
    from cocobench_agents.models.builtin import Script
    from cocobench_agents.models.human import HumanClient
    from cocobench_agents.models.protocol import ModelRequest

    assert TEAM_SEAT == "team"
    assert TEAM == REGISTRY_TEAM == CENTRALIZED_SEAT == Script.TEAM == TEAM_SEAT
    decision = HumanClient(desk=None, episode="e").decision(ModelRequest(prompt="p"))
    assert decision.seat == TEAM_SEAT
    context = PlannerContext(tools=None, clients={TEAM_SEAT: ModelPool().client(
        "greedy", episode="e", agent=None)}, budget=None)
    assert context.client_for(None) is context.client_for("agent_9") is \
        context.clients[TEAM_SEAT]


def test_no_module_spells_the_team_another_way():
    """The old history key of planner state, "__team__", is gone (the scripted format's
    old "centralized" key is read only as an alias: tests/models/test_builtin.py)."""
    spelled = []
    for name in modules():
        for node in nodes(name):
            if isinstance(node, ast.Constant) and node.value == "__team__":
                spelled.append(f"{name}:{node.lineno}")
    assert spelled == []
