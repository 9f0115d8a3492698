"""Compiled planner graphs for LangGraph tooling (`langgraph.json`: `langgraph dev`, Studio).

Each graph expects a `PlannerContext` as its runtime context (see `episode_runner.py` for how a
run builds one); opened in Studio they show the node structure of every strategy.
"""

from cocobench_agents.graphs.registry import compiled_graph

centralized = compiled_graph("centralized")
decentralized = compiled_graph("decentralized")
decentralized_broadcast = compiled_graph("decentralized-broadcast")
leader_worker = compiled_graph("leader-worker")
oracle = compiled_graph("oracle")
