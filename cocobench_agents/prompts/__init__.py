"""Versioned prompt suites, their rendering, and the reply parser."""

from cocobench_agents.prompts.fields import TEMPLATE_FIELDS
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
    check_unchanged,
    load_prompt_suite,
    shipped_suite_files,
)

__all__ = [
    "DEFAULT_SUITE", "TEMPLATE_FIELDS", "VARIANTS", "ParsedReply", "PromptInputs", "PromptSuite",
    "PromptSuiteError", "available_suites", "check_unchanged", "coordination_hint",
    "history_line", "load_prompt_suite", "parse_message", "parse_reply", "render_centralized",
    "render_distributed", "render_leader", "shipped_suite_files",
]
