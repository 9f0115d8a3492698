"""Errors of the AI2-THOR backend. Each one says what went wrong *and* what to do about it."""

from __future__ import annotations

INSTALL = "pip install 'cocobench-agents[thor]'   (or: pip install 'ai2thor>=5.0.0,<6')"
RENDERING = (
    "on a headless GPU server use platform CloudRendering: install the NVIDIA driver and "
    "Vulkan (sudo apt-get install libvulkan1 vulkan-tools; `vulkaninfo` must list your GPU); "
    "otherwise use platform Linux64 with an X display (e.g. `Xvfb :99 -screen 0 1024x768x24 &` "
    "then `export DISPLAY=:99`, or `sudo ai2thor-xorg start` on NVIDIA machines)"
)
PRE_DOWNLOADED = (
    "download the build once on a machine with network access and copy "
    "~/.ai2thor/releases/thor-<Platform>-<commit>/ to the same place here, or point at an "
    "unpacked build: COCOBENCH_THOR_BUILD=/path/to/thor-<Platform>-<commit>/thor-<Platform>-"
    "<commit> (ThorOptions.local_executable_path; see docs/ai2thor-backend.md)"
)


class ThorUnavailable(RuntimeError):
    """AI2-THOR cannot be used here; `remedy` says how to fix that."""

    def __init__(self, problem: str, remedy: str) -> None:
        self.problem, self.remedy = problem, remedy
        super().__init__(f"{problem}\n  To fix: {remedy}")


class ThorCrashed(RuntimeError):
    """The AI2-THOR process failed mid-episode; its session was shut down.

    The episode's world state is lost with it: call `reset()` to start the episode again.
    """


def not_installed() -> ThorUnavailable:
    """ai2thor is missing (the `thor` extra was not installed)."""
    return ThorUnavailable("the ai2thor package is not installed", INSTALL)


def wrong_version(found: str | None) -> ThorUnavailable:
    """An ai2thor release other than 5.x is installed."""
    return ThorUnavailable(
        f"ai2thor {found or '(unknown version)'} is installed; this backend needs ai2thor 5.x",
        INSTALL,
    )
