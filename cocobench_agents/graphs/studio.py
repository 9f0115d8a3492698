"""Compiled graphs for LangGraph tooling (`langgraph.json`: `langgraph dev`, Studio).

`episode` runs a whole episode from plain input (a task, a model, a planner): the graph to run
from a LangGraph server or Studio. The planner graphs expect a `PlannerContext` with a live
episode as their runtime context, which only `episode` (or `cocobench run`) builds; opened in
Studio they show the node structure of every strategy.
"""

from cocobench_agents.graphs.episode_graph import build_episode_graph
from cocobench_agents.graphs.registry import compiled_graph

episode = build_episode_graph().compile()

centralized = compiled_graph("centralized")
decentralized = compiled_graph("decentralized")
decentralized_broadcast = compiled_graph("decentralized-broadcast")
leader_worker = compiled_graph("leader-worker")
oracle = compiled_graph("oracle")
