"""The claim-board strategy, registered with cocobench through the entry point in
pyproject.toml.

The spec names its graph and round builders as strings (`lazy_builder`): listing planners or
planning a run reads this module without importing LangGraph.
"""

from cocobench_agents.graphs import PlannerSpec, lazy_builder

CLAIM_BOARD = PlannerSpec(
    name="claim-board",  # cocobench names it after the entry point
    code="CL",  # condition code: CL_image, CL_blind in --conditions, run folders, reports
    build=lazy_builder("cocobench_claim_board.graph:build_claim_board"),
    # Its round as plain functions, which episodes await directly, without LangGraph:
    rounds=lazy_builder("cocobench_claim_board.graph:claim_board_rounds"),
    decentralized=True,  # one model per agent (--agent-model works)
    uses_models=True,
    description="robots claim the object they will work on, in turn, on a shared board; "
                "a claimed object is off limits to teammates that round",
    # Its shape, which the dry run counts exactly (docs/planners.md, "What a spec declares"):
    loop="round",  # every robot is asked in each round, in team order
    calls_per_seat=2,  # a robot whose pick is claimed is asked once more
    prompt="agent",  # each robot's own prompt
    broadcast=True,  # with the message board
)
