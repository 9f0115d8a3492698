"""The paper's tables and plots from run folders, with bootstrap confidence intervals.

`build_report(["runs/a", "runs/b"], "out")` reads the runs (merged, later runs winning on
duplicate episodes) and writes Markdown and CSV tables, PNG plots (with matplotlib) and an
`index.md`. See docs/reports.md.
"""

from cocobench_agents.reports.build import ReportSummary, build_report, compute_tables
from cocobench_agents.reports.load import NotARunFolder, ReportData, ReportError, load_runs
from cocobench_agents.reports.stats import Bootstrap, Estimate
from cocobench_agents.reports.table import Column, Table

__all__ = ["Bootstrap", "Column", "Estimate", "NotARunFolder", "ReportData", "ReportError",
           "ReportSummary", "Table", "build_report", "compute_tables", "load_runs"]
