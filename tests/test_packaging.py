"""The design card's layout: two top-level packages, found exactly by pyproject; the wheel
carries both with their data files; tests import the installed distribution."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import zipfile
from importlib import metadata
from pathlib import Path

import pytest

import benchmark_adapter
import cocobench_agents

ROOT = Path(__file__).resolve().parents[1]


def test_the_packages_sit_at_the_top_level():
    for package in (benchmark_adapter, cocobench_agents):
        assert Path(package.__file__).resolve().parent.parent == ROOT
    assert not (ROOT / "src").exists()


def test_tests_import_the_installed_distribution():
    dist = metadata.distribution("cocobench-agents")
    direct = dist.read_text("direct_url.json")
    if direct and json.loads(direct).get("dir_info", {}).get("editable"):
        # an editable install maps the package names onto this checkout
        location = Path(json.loads(direct)["url"].removeprefix("file://"))
    else:
        location = Path(dist.locate_file(""))
    assert Path(cocobench_agents.__file__).resolve().is_relative_to(location.resolve())


@pytest.mark.slow
def test_the_wheel_holds_both_packages_and_their_data(tmp_path):
    # Built from a copy: an in-tree build would write build/ and egg-info into the checkout.
    source = tmp_path / "source"
    ignore = shutil.ignore_patterns("__pycache__", "*.egg-info", ".*", "runs")
    shutil.copytree(ROOT, source, ignore=ignore)
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation",
                    "--quiet", "-w", str(tmp_path), str(source)], check=True, timeout=300)
    (wheel,) = tmp_path.glob("cocobench_agents-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    tops = {n.split("/")[0] for n in names if not n.split("/")[0].endswith(".dist-info")}
    assert tops == {"benchmark_adapter", "cocobench_agents"}
    assert any(n.startswith("benchmark_adapter/data/cocobench-240/") and n.endswith(".json")
               for n in names)
    assert any(n.startswith("cocobench_agents/prompts/templates/cocobench-v1/")
               for n in names)
    for page_file in ("viewer/templates/base.html", "viewer/static/viewer.js",
                      "play/templates/play.html", "play/static/play.js", "play/static/play.css"):
        assert f"cocobench_agents/{page_file}" in names
    entry_points = next(n for n in names if n.endswith("entry_points.txt"))
    assert "cocobench = cocobench_agents.cli:main" in zipfile.ZipFile(wheel).read(
        entry_points).decode()
