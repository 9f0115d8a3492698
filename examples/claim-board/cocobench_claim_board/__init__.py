"""The claim-board strategy, registered with cocobench through the entry point in
pyproject.toml.

The spec names its graph builder as a string (`lazy_builder`): listing planners or planning a
run reads this module without importing LangGraph.
"""

from cocobench_agents.graphs import PlannerSpec, lazy_builder

CLAIM_BOARD = PlannerSpec(
    name="claim-board",  # cocobench names it after the entry point
    code="CL",  # condition code: CL_image, CL_blind in --conditions, run folders, reports
    build=lazy_builder("cocobench_claim_board.graph:build_claim_board"),
    decentralized=True,  # one model per agent (--agent-model works)
    uses_models=True,
    description="robots claim the object they will work on, in turn, on a shared board; "
                "a claimed object is off limits to teammates that round",
    prompt="agent",  # each robot's own prompt
    broadcast=True,  # with the message board: the dry run counts it
    # loop: not declared, since a robot may be asked twice in a round (none of "step",
    # "round", "led-round"); the dry run assumes one call per robot per landed step.
)
