"""Versioned prompt suites, their rendering, and the reply parser.

Names load on first use (PEP 562): the run request needs only `DEFAULT_SUITE`.
"""

from __future__ import annotations

from cocobench_agents.lazy import lazy_getattr

_EXPORTS = {
    "TEMPLATE_FIELDS": ".fields",
    "coordination_hint": ".hints",
    "ParsedReply": ".parse",
    "parse_message": ".parse",
    "parse_reply": ".parse",
    "PromptInputs": ".render",
    "history_line": ".render",
    "render_centralized": ".render",
    "render_distributed": ".render",
    "render_leader": ".render",
    "render_own": ".render",
    "DEFAULT_SUITE": ".suite",
    "PromptSuite": ".suite",
    "PromptSuiteError": ".suite",
    "VARIANTS": ".suite",
    "available_suites": ".suite",
    "merged_templates": ".suite",
    "check_unchanged": ".suite",
    "load_prompt_suite": ".suite",
    "shipped_suite_files": ".suite",
    "suite_label": ".suite",
    "suite_spec": ".suite",
}
__all__ = sorted(_EXPORTS)

__getattr__ = lazy_getattr(__name__, _EXPORTS)
