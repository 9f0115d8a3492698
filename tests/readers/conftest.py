"""A real run folder for the tests of its readers (`report`, `export`, `score`, `--resume`),
made once per session by `cocobench run` with the greedy model, with a canary planted in it:
a `.py` file and a module that record it when they are ever imported."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from cocobench_agents.cli import main
from tests.paths import SHARED_TASKS

TASKS = ("A_D1__FloorPlan1__seed0", "C_D4__FloorPlan1__seed0")
CONDITIONS = "C0_image,D1_blind"
#: The canary module's name: a directory holding it is put on sys.path by the tests.
CANARY_MODULE = "cocobench_canary_mod"
#: Where the run folder's canary file lies in it (a code reference names it relative to the
#: folder, which the tests make the working directory, or absolutely).
CANARY_FILE = Path("code") / "canary.py"
#: What the canary does when imported: it writes the file it is given, so that a test sees
#: that it ran (a planner's build function, never reached, would be the payload).
CANARY_SOURCE = """\
from pathlib import Path
Path({marker!r}).write_text("the canary ran")


def build_x():
    raise AssertionError("a planner from a run folder was built")


NAME = build_x
"""


@pytest.fixture(scope="session")
def demo_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """greedy over `TASKS` × `CONDITIONS` (4 episodes, 6 steps each). Read-only: copy it."""
    out = tmp_path_factory.mktemp("readers") / "demo"
    args = ["run", "--model", "greedy", "--conditions", CONDITIONS, "--out", str(out),
            "--max-steps", "6"]
    for task in TASKS:
        args += ["--task", str(SHARED_TASKS / f"{task}.json")]
    assert main(args) == 0
    return out


@pytest.fixture(scope="session")
def canary(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The file the canary writes when it runs (it must never exist); the canary module
    lies in the folder beside it."""
    home = tmp_path_factory.mktemp("canary")
    marker = home / "CANARY_RAN"
    (home / f"{CANARY_MODULE}.py").write_text(CANARY_SOURCE.format(marker=str(marker)))
    return marker


def planted_copy(demo_run: Path, canary: Path, where: Path) -> Path:
    """A copy of the demo run at `where`, its canary file planted in `code/`."""
    run = Path(shutil.copytree(demo_run, where))
    (run / CANARY_FILE).parent.mkdir()
    (run / CANARY_FILE).write_text(CANARY_SOURCE.format(marker=str(canary)))
    return run
