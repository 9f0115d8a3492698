"""Fixtures for the AI2-THOR backend tests: a private controller pool and the fake Unity.

Nothing here starts Unity or downloads a build. Tests that drive ai2thor's Python code are
marked `needs_thor` (they skip, with the reason, when ai2thor is not installed; CI installs it).
"""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Callable, Iterator

import pytest

from benchmark_adapter.sim.thor import ThorController, ThorOptions, environment
from benchmark_adapter.sim.thor.environment import Renderers
from benchmark_adapter.sim.thor.pool import ControllerPool
from benchmark_adapter.tasks import TaskConfig, load_task
from tests.paths import SHARED_TASKS

# The real configs live beside the repository: /work/shared/cocobench-data next to /work/main.
TASKS = SHARED_TASKS
SHARED_FILES = sorted(TASKS.glob("*.json")) if TASKS.is_dir() else []
needs_data = pytest.mark.skipif(
    not SHARED_FILES, reason=f"shared CoCoBench task configs not found at {TASKS}"
)
# A small two-agent config used by the contract tests.
SMALL = "A_D1__FloorPlan1__seed0.json"
# A Linux machine with neither Vulkan nor an X display.
NO_RENDERER = Renderers("Linux", None, None, None, None)


def probe_finds(monkeypatch: pytest.MonkeyPatch, found: Renderers) -> None:
    """Make the renderer probe report `found` instead of looking at this machine."""
    monkeypatch.setattr(environment, "probe", lambda x_display=None: found)


def python_stdout(*args: str) -> str:
    """Run `python *args` in a child process; its stdout, once it has exited cleanly."""
    out = subprocess.run([sys.executable, *args], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    return out.stdout


@pytest.fixture
def pool() -> Iterator[ControllerPool]:
    """A private pool without atexit/SIGTERM hooks, closed after the test."""
    p = ControllerPool(install_exit_hooks=False)
    yield p
    p.close()


def shared_library():
    """A fake Unity scene library holding every shared config's scene (all must be "in the
    build" before the first start)."""
    from .fake_unity import SceneLibrary

    lib = SceneLibrary()
    for path in SHARED_FILES:
        lib.add(load_task(path))
    return lib


@pytest.fixture
def library():
    """The fake Unity's scene library, holding every shared config's scene."""
    return shared_library()


@pytest.fixture
def make_thor(pool, library) -> Callable[..., ThorController]:
    """`make_thor(config, **options)`: a ThorController over the fake Unity."""
    from .fake_unity import fake_factory

    factory = fake_factory(library)

    def make(config: TaskConfig, **options) -> ThorController:
        library.add(config)
        return ThorController(config, ThorOptions(**options), factory=factory, pool=pool)

    return make


def shared_config(name: str = SMALL) -> TaskConfig:
    """One of the shared configs by file name."""
    return load_task(TASKS / name)
