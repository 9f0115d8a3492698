"""PNG plots: valid images, deterministic bytes, and a report without matplotlib."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest
from PIL import Image

from cocobench_agents.reports import ReportError, build_report
from cocobench_agents.reports.plots import INSTALL_HINT, PLOTS

from .helpers import RUN_ORACLE, RUN_SMALL


@pytest.fixture(scope="module")
def report(tmp_path_factory: pytest.TempPathFactory):
    out = tmp_path_factory.mktemp("report")
    return out, build_report([RUN_SMALL, RUN_ORACLE], out)


def test_every_figure_is_a_png(report) -> None:
    out, summary = report
    assert [p.file for p in summary.plots] == [name for name, _, _ in PLOTS]
    for entry in summary.plots:
        path = out / entry.file
        assert path.stat().st_size > 0
        with Image.open(path) as image:
            image.verify()
        with Image.open(path) as image:
            assert image.format == "PNG" and image.size[0] > 100 and image.size[1] > 100
            assert "Software" not in image.info  # no tool or date metadata
        assert path in summary.files
    index = (out / "index.md").read_text(encoding="utf-8")
    assert all(f"]({p.file})" in index for p in summary.plots)
    assert "Per-condition figures show C0_image." in index


def test_plots_are_deterministic(report, tmp_path: Path) -> None:
    out, summary = report
    import matplotlib.style

    tables = {t.name: t for t in summary.tables}
    with matplotlib.style.context("default"):
        for file, _, draw in PLOTS:
            if file in ("fig_by_dimension.png", "fig_correlation.png"):  # the two kinds
                assert draw(tables, tmp_path / file, "C0_image")
                assert (tmp_path / file).read_bytes() == (out / file).read_bytes()


def test_plot_condition_can_be_chosen(tmp_path: Path) -> None:
    summary = build_report([RUN_SMALL, RUN_ORACLE], tmp_path, plots=False,
                           condition="OR_image")
    assert summary.plot_condition == "OR_image"
    with pytest.raises(ReportError, match="no episodes under it"):
        build_report([RUN_SMALL], tmp_path, plots=False, condition="OR_image")


def test_without_matplotlib_tables_are_still_written(tmp_path: Path,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    for name in [m for m in sys.modules if m == "matplotlib" or m.startswith("matplotlib.")]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, "matplotlib", None)  # `import matplotlib` fails
    summary = build_report([RUN_SMALL], tmp_path)
    assert summary.plots == [] and summary.plot_note == INSTALL_HINT
    assert "pip install matplotlib" in summary.plot_note
    assert (tmp_path / "main_results.md").exists() and (tmp_path / "cost.csv").exists()
    assert not list(tmp_path.glob("*.png"))
    assert INSTALL_HINT in (tmp_path / "index.md").read_text(encoding="utf-8")
