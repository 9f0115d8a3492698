"""Trajectories as datasets (`cocobench export`): the model decisions of run folders as one
Parquet file that Hugging Face `datasets` loads as it is, with a dataset card beside it.

Reads run folders only through `cocobench_agents.runfolder`; writes with pyarrow (the
`export` extra), imported only when an export is written. Names load on first use (PEP 562).
"""

from __future__ import annotations

from cocobench_agents.lazy import lazy_getattr

_EXPORTS = {
    "export_runs": ".build", "ExportSummary": ".build", "CARD_FILE": ".build",
    "ExportError": ".errors", "ExportWriteError": ".errors",
    "COLUMNS": ".columns", "SELECTORS": ".selection", "Selection": ".selection",
    "DATA_FILE": ".writer",
}
__all__ = sorted(_EXPORTS)

__getattr__ = lazy_getattr(__name__, _EXPORTS)
