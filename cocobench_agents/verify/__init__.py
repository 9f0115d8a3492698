"""Verifying runs: every recorded episode replayed through the embedded simulator and every
metric recomputed (`replay`), over a run folder or a submission bundle (`run`); bundles
packed and read back as data only (`bundle`).

Names load on first use (PEP 562).
"""

from __future__ import annotations

from cocobench_agents.lazy import lazy_getattr

_EXPORTS = {
    "Verdict": ".replay", "first_difference": ".replay",
    "replay": ".replay", "verify_episode": ".replay",
    "RunVerification": ".run", "reference_configs": ".run", "verify_run": ".run",
    "verify_source": ".run",
    "VerifyError": ".errors", "BundleWriteError": ".errors",
    "VerifyStopped": ".errors",
    "open_bundle": ".bundle", "pack": ".bundle",
}
__all__ = sorted(_EXPORTS)

__getattr__ = lazy_getattr(__name__, _EXPORTS)
