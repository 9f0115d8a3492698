"""The planner graphs compiled for LangGraph tooling (`langgraph.json`: `langgraph dev`,
Studio).

The planner graphs expect a `PlannerContext` with a live episode as their runtime context,
which only the `episode` graph (`cocobench_agents/episode_graph.py`) or `cocobench run` builds;
opened in Studio they show the node structure of every strategy.
"""

from cocobench_agents.graphs.lookup import compiled_graph

centralized = compiled_graph("centralized")
decentralized = compiled_graph("decentralized")
decentralized_broadcast = compiled_graph("decentralized-broadcast")
leader_worker = compiled_graph("leader-worker")
oracle = compiled_graph("oracle")
