"""The leaderboard: a static site built only from what verifies (issue 40).

Names load on first use (PEP 562).
"""

from __future__ import annotations

from cocobench_agents.lazy import lazy_getattr

_EXPORTS = {"Leaderboard": ".build", "build_leaderboard": ".build", "Row": ".rows",
            "SiteWriteError": ".build"}
__all__ = sorted(_EXPORTS)

__getattr__ = lazy_getattr(__name__, _EXPORTS)
