"""cocobench-agents: benchmark any LLM or VLM as a multi-agent household planner on CoCoBench."""

__version__ = "0.1.0"
