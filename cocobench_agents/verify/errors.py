"""What `cocobench verify` and `cocobench submit` report as a user's mistake (exit 2), and a
file they could not write (exit 1)."""

from __future__ import annotations


class VerifyError(ValueError):
    """A path that is no run folder or bundle, a bundle refused, a setting out of range."""


class BundleWriteError(RuntimeError):
    """A bundle or report that could not be written: a full or read-only disk (exit 1)."""


class VerifyStopped(RuntimeError):
    """A verification that ended before every episode was judged (a worker killed): no
    verdict (exit 1)."""
