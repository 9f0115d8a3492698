"""The backend registry, `ThorOptions`, and that importing the project never imports ai2thor."""

from __future__ import annotations

import pickle
import sys

import pytest

from benchmark_adapter.sim.backends import BACKENDS, controller_factory, make_controller
from benchmark_adapter.sim.embedded import EmbeddedController
from benchmark_adapter.sim.thor import ThorController, ThorOptions

from .conftest import (
    NO_RENDERER,
    needs_data,
    probe_finds,
    python_stdout,
    shared_config,
)


def test_backends_are_registered_by_name():
    assert set(BACKENDS) == {"embedded", "ai2thor"}


@needs_data
def test_embedded_is_the_default():
    assert isinstance(make_controller(shared_config()), EmbeddedController)


@needs_data
def test_ai2thor_backend_builds_a_thor_controller_without_starting_anything():
    ctl = make_controller(shared_config(), "ai2thor", platform="Linux64", width=640)
    assert isinstance(ctl, ThorController)
    assert ctl.options.platform == "Linux64" and ctl.options.width == 640
    assert ctl.backend == "ai2thor" and ctl.agent_count == 2


@needs_data
def test_unknown_backend_names_the_choices():
    with pytest.raises(
        ValueError, match="unknown backend 'unity'; choose one of: ai2thor, embedded"
    ):
        make_controller(shared_config(), "unity")


@needs_data
def test_options_are_checked():
    with pytest.raises(ValueError, match="embedded backend takes no options"):
        make_controller(shared_config(), "embedded", width=400)
    with pytest.raises(ValueError, match=r"unknown ai2thor backend option\(s\): widht"):
        make_controller(shared_config(), "ai2thor", widht=400)


def test_controller_factory_checks_early_and_pickles():
    with pytest.raises(ValueError, match="unknown backend"):
        controller_factory("unity")
    with pytest.raises(ValueError, match="platform must be one of"):
        controller_factory("ai2thor", platform="Windows")
    factory = pickle.loads(pickle.dumps(controller_factory("ai2thor", quality="Medium")))
    assert factory.keywords == {"backend": "ai2thor", "quality": "Medium"}


def test_thor_options_never_render_below_300():
    options = ThorOptions(width=144, height=144)
    assert (options.width, options.height) == (300, 300)
    with pytest.raises(ValueError, match="lookup_timeout must be > 0"):
        ThorOptions(lookup_timeout=0)


def test_thor_options_from_the_environment():
    environ = {
        "COCOBENCH_THOR_PLATFORM": "CloudRendering",
        "COCOBENCH_THOR_GPU_DEVICE": "1",
        "COCOBENCH_THOR_BUILD": "/opt/thor/thor-CloudRendering-abc",
        "COCOBENCH_THOR_LOOKUP_TIMEOUT": "5.5",
    }
    options = ThorOptions.from_env(environ, gpu_device=2)
    assert options.platform == "CloudRendering"
    assert options.gpu_device == 2  # an explicit option wins
    assert options.local_executable_path == "/opt/thor/thor-CloudRendering-abc"
    assert options.lookup_timeout == 5.5
    with pytest.raises(ValueError, match="COCOBENCH_THOR_WIDTH='big' is not a number"):
        ThorOptions.from_env({"COCOBENCH_THOR_WIDTH": "big"})


def test_pool_key_ignores_what_does_not_change_the_process():
    assert ThorOptions(lookup_timeout=5).pool_key() == ThorOptions().pool_key()
    assert ThorOptions(width=400).pool_key() != ThorOptions().pool_key()


def test_importing_the_project_does_not_import_ai2thor():
    script = (
        "import sys\n"
        "import benchmark_adapter, benchmark_adapter.sim.backends, benchmark_adapter.sim.thor\n"
        "import benchmark_adapter.sim.thor.launch, cocobench_agents.cli.doctor_cmd\n"
        "from benchmark_adapter.sim.thor import ThorOptions\n"
        "ThorOptions()\n"
        "print(sorted(m for m in sys.modules if m.split('.')[0] == 'ai2thor'))\n"
    )
    assert python_stdout("-c", script).strip() == "[]"


def test_check_backend_fails_fast_without_starting_anything(monkeypatch):
    from benchmark_adapter.sim.backends import check_backend
    from benchmark_adapter.sim.thor import ThorUnavailable

    check_backend("embedded")
    with pytest.raises(ValueError, match="unknown backend"):
        check_backend("unity")
    probe_finds(monkeypatch, NO_RENDERER)
    with monkeypatch.context() as hidden:
        hidden.setitem(sys.modules, "ai2thor", None)
        with pytest.raises(ThorUnavailable, match="not installed"):
            check_backend("ai2thor")


@pytest.mark.needs_thor
def test_check_backend_names_a_missing_renderer(monkeypatch):
    from benchmark_adapter.sim.backends import check_backend
    from benchmark_adapter.sim.thor import ThorUnavailable

    probe_finds(monkeypatch, NO_RENDERER)
    with pytest.raises(ThorUnavailable, match="neither Vulkan nor an X display"):
        check_backend("ai2thor")
