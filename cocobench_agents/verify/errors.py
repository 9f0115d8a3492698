"""What `cocobench verify` and `cocobench submit` report as a user's mistake (exit 2)."""

from __future__ import annotations


class VerifyError(ValueError):
    """A path that is no run folder or bundle, a bundle refused, a setting out of range."""
