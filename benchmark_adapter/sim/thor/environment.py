"""What this machine offers AI2-THOR: Vulkan, an X display, a cached build. No ai2thor import.

AI2-THOR 5.0 renders either through Vulkan without any display (platform CloudRendering, for
headless GPU servers) or through an X11 display with GLX (platform Linux64, e.g. under Xvfb).
These probes let us say which one will work *before* Unity is started.
"""

from __future__ import annotations

import ctypes.util
import os
import platform as _platform
import shutil
from dataclasses import dataclass
from pathlib import Path

from benchmark_adapter.sim.thor.errors import PRE_DOWNLOADED, RENDERING, ThorUnavailable
from benchmark_adapter.sim.thor.options import ThorOptions


@dataclass(frozen=True)
class Renderers:
    """The rendering back-ends this machine can offer Unity."""

    system: str
    vulkan: str | None  # the Vulkan loader library, if found
    vulkaninfo: str | None  # path of the `vulkaninfo` tool (ai2thor runs it for gpu_device)
    nvidia_smi: str | None
    display: str | None  # the X display to use, if any


def probe(x_display: str | None = None) -> Renderers:
    """Look for Vulkan and an X display (an explicit `x_display` wins over $DISPLAY)."""
    return Renderers(
        system=_platform.system(),
        vulkan=ctypes.util.find_library("vulkan"),
        vulkaninfo=shutil.which("vulkaninfo"),
        nvidia_smi=shutil.which("nvidia-smi"),
        display=x_display or os.environ.get("DISPLAY") or None,
    )


def choose_platform(options: ThorOptions, found: Renderers | None = None) -> str:
    """The ai2thor platform to run, checked against this machine; raises `ThorUnavailable`."""
    found = found or probe(options.x_display)
    wanted = options.platform
    if found.system == "Darwin":
        return "OSXIntel64"
    if found.system != "Linux":
        raise ThorUnavailable(
            f"AI2-THOR 5.0 has builds for Linux and macOS only, not {found.system}",
            "run on Linux (a GPU server with CloudRendering) or macOS, e.g. via WSL2 or a VM",
        )
    if wanted == "auto":
        wanted = "CloudRendering" if found.vulkan else "Linux64" if found.display else ""
    if wanted == "CloudRendering":
        _check_cloud_rendering(options, found)
    elif wanted == "Linux64":
        _check_x_display(found)
    elif wanted == "OSXIntel64":
        raise ThorUnavailable("platform OSXIntel64 runs on macOS only", RENDERING)
    else:
        raise ThorUnavailable("neither Vulkan nor an X display is available", RENDERING)
    return wanted


def _check_cloud_rendering(options: ThorOptions, found: Renderers) -> None:
    if not found.vulkan:
        raise ThorUnavailable(
            "platform CloudRendering needs the Vulkan loader (libvulkan.so.1), which is missing",
            RENDERING,
        )
    if options.gpu_device is not None and not (found.vulkaninfo and found.nvidia_smi):
        raise ThorUnavailable(
            f"gpu_device={options.gpu_device} needs `vulkaninfo` and `nvidia-smi` on PATH "
            "(ai2thor maps CUDA to Vulkan device ids with them)",
            "sudo apt-get install vulkan-tools and the NVIDIA driver utilities, or leave "
            "gpu_device unset to use the first GPU",
        )


def _check_x_display(found: Renderers) -> None:
    if not found.display:
        raise ThorUnavailable(
            "platform Linux64 needs an X display, and DISPLAY is not set",
            RENDERING,
        )


def check_local_executable(path: str | None) -> None:
    """A user-supplied build must be an executable file."""
    if path is None:
        return
    build = Path(path).expanduser()
    if not build.is_file():
        raise ThorUnavailable(
            f"no AI2-THOR build at {build} (local_executable_path)", PRE_DOWNLOADED
        )
    if not os.access(build, os.X_OK):
        raise ThorUnavailable(f"{build} is not executable", f"chmod +x {build}")


def preflight(options: ThorOptions, found: Renderers | None = None) -> str:
    """Every check that needs no ai2thor import and no Unity; returns the platform to use."""
    check_local_executable(options.local_executable_path)
    return choose_platform(options, found)


def releases_dir() -> Path:
    """Where ai2thor caches downloaded builds."""
    return Path.home() / ".ai2thor" / "releases"


def cached_builds() -> list[Path]:
    """Unpacked builds in ai2thor's cache, newest first."""
    root = releases_dir()
    if not root.is_dir():
        return []
    builds = [p for p in root.iterdir() if p.is_dir() and p.name.startswith("thor-")]
    return sorted(builds, key=lambda p: p.stat().st_mtime, reverse=True)


def build_name(platform: str, commit_id: str) -> str:
    """ai2thor's folder name of a build (`thor-<Platform>-<commit>`)."""
    return f"thor-{platform}-{commit_id}"
