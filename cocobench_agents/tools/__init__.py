"""The tool adapter between planner graphs and an `Episode`."""

from cocobench_agents.models.protocol import prompt_text
from cocobench_agents.tools.decisions import (
    model_decision,
    prompt_hash,
    reply_fields,
    stop_decision,
)
from cocobench_agents.tools.episode_tools import EpisodeTools

__all__ = ["EpisodeTools", "model_decision", "prompt_hash", "prompt_text",
           "reply_fields", "stop_decision"]
