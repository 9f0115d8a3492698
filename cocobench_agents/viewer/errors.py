"""The viewer's user errors (one line, exit code 2: registered in the CLI's USER_ERRORS)."""

from __future__ import annotations


class ViewerError(ValueError):
    """A viewer that cannot start as asked: a missing run folder, a port in use, an export
    folder that is not empty."""
