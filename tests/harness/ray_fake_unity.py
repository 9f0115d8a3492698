"""The ai2thor backend over the contract tests' fake Unity, in Ray workers too.

`install` is a Ray worker setup hook: every worker process of the test's Ray session then
builds its `ThorController`s (with the process-wide controller pool, as in production) over
`tests/thor/fake_unity.py`. A test steers it through a control folder (the variable
`CONTROL_VARIABLE` names it): ``tasks.json`` lists the task config files whose scenes are "in
the build"; ``plan.json`` = ``{task_id: mode}`` makes a task's Unity die at its first step:
``once`` (a marker file makes it once across processes), ``always``, ``exit`` (the whole
worker process dies with it, once), or ``hold`` (once: it hangs there, after writing the Ray
node it runs on to ``TASK_ID.held``, until the test takes that node down).
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from benchmark_adapter.sim import backends
from benchmark_adapter.sim.thor import ThorController, ThorOptions, environment
from benchmark_adapter.sim.thor.environment import Renderers
from benchmark_adapter.sim.thor.pool import POOL, ControllerPool
from benchmark_adapter.tasks import TaskConfig, load_task

CONTROL_VARIABLE = "COCOBENCH_TEST_FAKE_UNITY"
UNITY_EXITED = "Unity exited"
HOLD_S = 600.0  # a held episode's bound, should its node never be taken down
VULKAN = Renderers("Linux", "libvulkan.so.1", "/usr/bin/vulkaninfo", "/usr/bin/nvidia-smi", None)
NO_RENDERER = Renderers("Linux", None, None, None, None)


class Crash(dict):
    """A fake server's `fail_on`: when armed, the next episode action kills "Unity"."""

    def __init__(self) -> None:
        super().__init__()
        self.armed: str | None = None
        self.held: Path | None = None  # where a held episode says which node holds it

    def __contains__(self, action: object) -> bool:
        from tests.thor.fake_unity import META_ACTIONS  # needs ai2thor: imported on use

        if self.armed is None or action in META_ACTIONS or action == "Initialize":
            return False
        if self.armed == "exit":
            os._exit(1)  # Unity took its worker process down with it
        if self.armed == "hold" and self.held is not None:
            import ray

            self.held.write_text(ray.get_runtime_context().get_node_id())
            time.sleep(HOLD_S)  # the test kills this node meanwhile
        return True

    def pop(self, action: Any, *default: Any) -> BaseException:
        self.armed = None
        return OSError(UNITY_EXITED)


def fake_thor_backend(control: Path, pool: ControllerPool = POOL
                      ) -> Callable[..., ThorController]:
    """A `BACKENDS["ai2thor"]` factory: ThorControllers over the fake Unity, in `pool`."""
    crash = Crash()
    start: list[Callable[..., Any]] = []  # the fake Unity, made on first use

    def factory(options: ThorOptions, scene: str, init: Any) -> Any:
        # The fake Unity needs ai2thor: imported on use, so that the Ray tests load without it.
        from tests.thor.fake_unity import SceneLibrary, fake_factory

        if not start:
            library = SceneLibrary()
            for path in json.loads((control / "tasks.json").read_text()):
                library.add(load_task(path))  # every scene "in the build" before a start
            start.append(fake_factory(library))
        controller = start[0](options, scene, init)
        controller.server.fail_on = crash
        return controller

    def make(config: TaskConfig, **options: Any) -> ThorController:
        crash.armed = _crash_mode(control, config.task_id)
        crash.held = control / f"{config.task_id}.held"
        return ThorController(config, ThorOptions(**options), factory=factory, pool=pool)

    return make


def _crash_mode(control: Path, task_id: str) -> str | None:
    plan_file = control / "plan.json"
    mode = json.loads(plan_file.read_text()).get(task_id) if plan_file.exists() else None
    if mode in (None, "always"):
        return mode and "crash"
    try:  # once across every process of the run
        os.close(os.open(control / f"{task_id}.{mode}", os.O_CREAT | os.O_EXCL))
    except FileExistsError:
        return None
    return mode if mode in ("exit", "hold") else "crash"


def install() -> None:
    """Ray worker setup hook: this process's ai2thor backend is the fake Unity, and its
    renderer probe finds Vulkan unless ``no-renderer`` is in the control folder."""
    control = Path(os.environ[CONTROL_VARIABLE])
    backends.BACKENDS["ai2thor"] = fake_thor_backend(control)
    environment.probe = lambda x_display=None: (
        NO_RENDERER if (control / "no-renderer").exists() else VULKAN)
