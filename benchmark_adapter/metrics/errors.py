"""The one error type the metrics raise."""

from __future__ import annotations


class TrajectoryError(ValueError):
    """A trajectory lacks (or mistypes) a field the metrics need.

    ``field`` names the offending field as a path into the trajectory JSON, e.g.
    ``"task_config"`` or ``"trajectory[3].skill_result.skill"``, so a caller can
    report exactly which recorded file is broken and where.
    """

    def __init__(self, field: str, message: str) -> None:
        super().__init__(f"{field}: {message}")
        self.field = field
        self.message = message
