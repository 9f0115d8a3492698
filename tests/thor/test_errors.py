"""Each way AI2-THOR can be unavailable gives a `ThorUnavailable` that says what to do.

Not installed (simulated by hiding the import), no Vulkan nor X display, a build lookup or
download that would hang, no build to be had, a bad local build, Unity failing to start.
None of these starts Unity or touches the network: ai2thor's lookups are monkeypatched.
"""

from __future__ import annotations

import sys
import threading
import time
import types
from collections.abc import Iterator

import pytest

from benchmark_adapter.sim.backends import make_controller
from benchmark_adapter.sim.thor import (
    ThorController,
    ThorOptions,
    ThorUnavailable,
    environment,
    launch,
)
from benchmark_adapter.sim.thor.build import BuildGuard, LocalBuild, within
from benchmark_adapter.sim.thor.environment import Renderers, choose_platform, preflight
from benchmark_adapter.sim.thor.loader import require_ai2thor

from .conftest import NO_RENDERER, needs_data, probe_finds, shared_config

VULKAN = Renderers("Linux", "libvulkan.so.1", "/usr/bin/vulkaninfo", "/usr/bin/nvidia-smi", None)
X_ONLY = Renderers("Linux", None, None, None, ":0")


# -- not installed ---------------------------------------------------------------------


def hide_ai2thor(monkeypatch: pytest.MonkeyPatch) -> None:
    """Make `import ai2thor` fail as if the package were absent."""
    for name in [m for m in sys.modules if m == "ai2thor" or m.startswith("ai2thor.")]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, "ai2thor", None)


def test_missing_ai2thor_says_which_extra_to_install(monkeypatch):
    hide_ai2thor(monkeypatch)
    with pytest.raises(ThorUnavailable) as caught:
        require_ai2thor()
    assert "not installed" in caught.value.problem
    assert "pip install 'cocobench-agents[thor]'" in caught.value.remedy
    assert "pip install 'cocobench-agents[thor]'" in str(caught.value)


@needs_data
def test_missing_ai2thor_surfaces_at_reset_not_at_construction(monkeypatch, pool):
    hide_ai2thor(monkeypatch)
    ctl = ThorController(shared_config(), pool=pool)  # building the adapter imports nothing
    with pytest.raises(ThorUnavailable, match=r"cocobench-agents\[thor\]"):
        ctl.reset()
    assert len(pool) == 0


@needs_data
def test_make_controller_ai2thor_without_ai2thor(monkeypatch):
    hide_ai2thor(monkeypatch)
    ctl = make_controller(shared_config(), "ai2thor")
    with pytest.raises(ThorUnavailable, match="not installed"):
        ctl.reset()


def fake_ai2thor(monkeypatch: pytest.MonkeyPatch, version: str, broken: str = "") -> None:
    """Install stand-in `ai2thor` modules (so this runs without the real package)."""
    top = types.ModuleType("ai2thor")
    top.__version__ = version  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "ai2thor", top)
    for sub in ("controller", "server", "platform"):
        name = f"ai2thor.{sub}"
        monkeypatch.setitem(sys.modules, name, None if sub == broken else types.ModuleType(name))


def test_broken_ai2thor_install_is_not_called_missing(monkeypatch):
    fake_ai2thor(monkeypatch, "5.0.0", broken="platform")
    with pytest.raises(ThorUnavailable, match="installed but cannot be imported") as caught:
        require_ai2thor()
    assert "reinstall" in caught.value.remedy


def test_wrong_ai2thor_version(monkeypatch):
    fake_ai2thor(monkeypatch, "4.3.0")
    with pytest.raises(ThorUnavailable, match=r"ai2thor 4\.3\.0 .* needs ai2thor 5\.x"):
        require_ai2thor()


# -- rendering: Vulkan / X display -----------------------------------------------------


def test_no_vulkan_and_no_display_explains_both_platforms():
    with pytest.raises(ThorUnavailable) as caught:
        choose_platform(ThorOptions(), NO_RENDERER)
    assert "neither Vulkan nor an X display" in caught.value.problem
    for hint in ("CloudRendering", "libvulkan1", "vulkaninfo", "Linux64", "Xvfb", "DISPLAY"):
        assert hint in caught.value.remedy


def test_auto_prefers_cloud_rendering_then_an_x_display():
    assert choose_platform(ThorOptions(), VULKAN) == "CloudRendering"
    assert choose_platform(ThorOptions(), X_ONLY) == "Linux64"
    assert choose_platform(ThorOptions(), Renderers("Darwin", None, None, None, None)) == (
        "OSXIntel64"
    )


def test_cloud_rendering_without_vulkan():
    with pytest.raises(ThorUnavailable, match="needs the Vulkan loader"):
        choose_platform(ThorOptions(platform="CloudRendering"), X_ONLY)


def test_linux64_without_display():
    with pytest.raises(ThorUnavailable, match="needs an X display") as caught:
        choose_platform(ThorOptions(platform="Linux64"), VULKAN)
    assert "Xvfb" in caught.value.remedy


def test_gpu_device_needs_vulkaninfo_and_nvidia_smi():
    no_tools = Renderers("Linux", "libvulkan.so.1", None, None, None)
    with pytest.raises(ThorUnavailable, match="vulkaninfo") as caught:
        choose_platform(ThorOptions(gpu_device=1), no_tools)
    assert "vulkan-tools" in caught.value.remedy
    assert choose_platform(ThorOptions(gpu_device=1), VULKAN) == "CloudRendering"


def test_unsupported_operating_system():
    with pytest.raises(ThorUnavailable, match="Linux and macOS only"):
        choose_platform(ThorOptions(), Renderers("Windows", None, None, None, None))


def test_probe_reads_display_and_explicit_display_wins(monkeypatch):
    monkeypatch.setenv("DISPLAY", ":7")
    assert environment.probe().display == ":7"
    assert environment.probe(":9").display == ":9"
    monkeypatch.delenv("DISPLAY")
    assert environment.probe().display is None


@pytest.mark.needs_thor
@needs_data
def test_no_renderer_is_reported_before_anything_starts(monkeypatch, pool):
    probe_finds(monkeypatch, NO_RENDERER)
    with pytest.raises(ThorUnavailable, match="neither Vulkan nor an X display"):
        ThorController(shared_config(), pool=pool).reset()
    assert len(pool) == 0


# -- local builds ----------------------------------------------------------------------


def test_missing_local_build(tmp_path):
    with pytest.raises(ThorUnavailable, match="no AI2-THOR build at") as caught:
        preflight(ThorOptions(local_executable_path=str(tmp_path / "thor")), VULKAN)
    assert "COCOBENCH_THOR_BUILD" in caught.value.remedy


def test_local_build_must_be_executable(tmp_path):
    build = tmp_path / "thor-CloudRendering-abc"
    build.write_text("")
    with pytest.raises(ThorUnavailable, match="not executable") as caught:
        preflight(ThorOptions(local_executable_path=str(build)), VULKAN)
    assert caught.value.remedy == f"chmod +x {build}"
    build.chmod(0o755)
    assert preflight(ThorOptions(local_executable_path=str(build)), VULKAN) == "CloudRendering"


def test_local_build_keeps_the_chosen_platform():
    # ai2thor's own ExternalBuild would launch a CloudRendering build as Linux64 (needs X).
    guard = BuildGuard(1.0, 1.0, local_executable_path="~/builds/thor")
    build = guard.obtain(pytest.fail, False, None, None, "CloudRenderingPlatform")
    assert isinstance(build, LocalBuild)
    assert build.platform == "CloudRenderingPlatform"
    assert build.executable_path.endswith("/builds/thor") and "~" not in build.executable_path
    assert list(build.server_types) == ["FIFO", "WSGI"]


# -- build lookup and download, under deadlines ----------------------------------------


def test_within_returns_raises_or_gives_up():
    assert within(1.0, "adding", lambda: 1 + 1) == 2
    with pytest.raises(KeyError):
        within(1.0, "failing", lambda: {}["x"])
    gate = threading.Event()
    start = time.perf_counter()
    with pytest.raises(TimeoutError, match=r"waiting did not finish within 0\.1 s"):
        within(0.1, "waiting", gate.wait)
    assert time.perf_counter() - start < 2
    gate.set()


@pytest.fixture
def offline_home(monkeypatch, tmp_path) -> Iterator[threading.Event]:
    """An empty ~/.ai2thor, a machine with Vulkan, and a gate that hung calls wait on (tests
    using it are marked `needs_thor`: ai2thor's build lookup code)."""
    monkeypatch.setenv("HOME", str(tmp_path))
    probe_finds(monkeypatch, VULKAN)
    gate = threading.Event()
    yield gate
    gate.set()  # let the abandoned lookup threads finish


def thor_with(pool, **options) -> ThorController:
    return ThorController(shared_config(), ThorOptions(**options), pool=pool)


def build_exists(monkeypatch: pytest.MonkeyPatch, missing: tuple[str, ...] = ()) -> None:
    """ai2thor finds a CloudRendering build online whose check of this machine lacks `missing`."""
    import ai2thor.build
    import ai2thor.platform

    monkeypatch.setattr(ai2thor.build.Build, "exists", lambda self: True)
    monkeypatch.setattr(
        ai2thor.platform.CloudRendering, "validate", classmethod(lambda c, r: list(missing))
    )


@pytest.mark.needs_thor
@needs_data
def test_hanging_build_lookup_times_out_with_a_way_out(monkeypatch, offline_home, pool):
    import ai2thor.build

    monkeypatch.setattr(ai2thor.build.Build, "exists", lambda self: offline_home.wait(30))
    start = time.perf_counter()
    with pytest.raises(ThorUnavailable) as caught:
        thor_with(pool, lookup_timeout=0.3).reset()
    assert time.perf_counter() - start < 5
    assert "looking up the AI2-THOR build did not finish within 0.3 s" in caught.value.problem
    for hint in ("~/.ai2thor/releases", "COCOBENCH_THOR_BUILD", "COCOBENCH_THOR_LOOKUP_TIMEOUT"):
        assert hint in caught.value.remedy
    assert len(pool) == 0


@pytest.mark.needs_thor
@needs_data
def test_hanging_download_times_out(monkeypatch, offline_home, pool):
    import ai2thor.build

    build_exists(monkeypatch)
    monkeypatch.setattr(ai2thor.build.Build, "download", lambda self: offline_home.wait(30))
    with pytest.raises(ThorUnavailable, match=r"downloading thor-CloudRendering-\w+ did not"):
        thor_with(pool, download_timeout=0.3).reset()


@pytest.mark.needs_thor
@needs_data
def test_no_build_available(monkeypatch, offline_home, pool):
    import ai2thor.build

    monkeypatch.setattr(ai2thor.build.Build, "exists", lambda self: False)
    with pytest.raises(ThorUnavailable, match="no AI2-THOR build could be obtained") as caught:
        thor_with(pool).reset()
    assert "no build exists" in caught.value.problem.lower()  # ai2thor's own words, kept
    assert "local_executable_path" in caught.value.remedy


@pytest.mark.needs_thor
@needs_data
def test_failed_download(monkeypatch, offline_home, pool):
    import ai2thor.build

    def refuse(self):
        raise ConnectionError("Name or service not known")

    build_exists(monkeypatch)
    monkeypatch.setattr(ai2thor.build.Build, "download", refuse)
    with pytest.raises(ThorUnavailable, match="Name or service not known"):
        thor_with(pool).reset()


@pytest.mark.needs_thor
@needs_data
def test_build_whose_platform_cannot_run_here(monkeypatch, offline_home, pool):
    build_exists(monkeypatch, missing=("Vulkan missing",))
    with pytest.raises(ThorUnavailable, match="missing dependencies") as caught:
        thor_with(pool).reset()
    assert "Xvfb" in caught.value.remedy


@pytest.mark.needs_thor
@needs_data
def test_unity_failing_to_start_points_at_its_logs(monkeypatch, offline_home, pool):
    class CrashingController:
        def __init__(self, **kwargs):
            raise Exception("Unity process has exited - check Player.log")

    monkeypatch.setattr(launch, "guarded_controller_class", lambda: CrashingController)
    with pytest.raises(ThorUnavailable, match="did not start on CloudRendering") as caught:
        thor_with(pool).reset()
    assert "Player.log" in caught.value.remedy


# -- scenes ----------------------------------------------------------------------------


def test_embedded_only_scenes_are_refused_clearly():
    from benchmark_adapter.tasks import load_tasks

    demo = load_tasks("demo")[0]
    with pytest.raises(ValueError, match="not an AI2-THOR scene"):
        ThorController(demo)


@pytest.mark.needs_thor
@needs_data
def test_a_cached_build_is_used_without_the_network(monkeypatch, offline_home, tmp_path):
    import ai2thor.build
    import ai2thor.platform

    def no_network(*args, **kwargs):
        raise AssertionError("the network was used")

    name = f"thor-CloudRendering-{ai2thor.build.COMMIT_ID}"
    cached = tmp_path / ".ai2thor" / "releases" / name
    cached.mkdir(parents=True)
    (cached / "metadata.json").write_text('{"server_types": ["FIFO"]}')
    monkeypatch.setattr(ai2thor.build.requests, "head", no_network)
    monkeypatch.setattr(ai2thor.build.requests, "get", no_network)
    monkeypatch.setattr(ai2thor.platform.CloudRendering, "validate", classmethod(lambda c, r: []))
    # The guarded find_build on a bare instance: the attributes ai2thor's lookup reads.
    cls = launch.guarded_controller_class()
    thor = cls.__new__(cls)
    thor._guard = BuildGuard(5.0, 5.0)
    thor.width = thor.height = 300
    thor.x_display, thor.headless, thor.include_private_scenes = None, False, False
    build = thor.find_build(False, ai2thor.build.COMMIT_ID, None, ai2thor.platform.CloudRendering)
    assert build.base_dir == str(cached)
    assert build.server_types == ["FIFO"]
