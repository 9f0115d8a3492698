"""Versioned prompt suites, their rendering, and the reply parser."""

from cocobench_agents.prompts.hints import coordination_hint
from cocobench_agents.prompts.parse import ParsedReply, parse_message, parse_reply
from cocobench_agents.prompts.render import (
    PromptInputs,
    history_line,
    render_centralized,
    render_distributed,
    render_leader,
)
from cocobench_agents.prompts.suite import (
    DEFAULT_SUITE,
    VARIANTS,
    PromptSuite,
    PromptSuiteError,
    available_suites,
    load_prompt_suite,
)

__all__ = [
    "DEFAULT_SUITE", "VARIANTS", "ParsedReply", "PromptInputs", "PromptSuite", "PromptSuiteError",
    "available_suites", "coordination_hint", "history_line", "load_prompt_suite",
    "parse_message", "parse_reply", "render_centralized", "render_distributed", "render_leader",
]
