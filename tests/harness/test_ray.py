"""The Ray executor on a real local Ray (2 CPUs, 1 logical GPU), shared by this module: a Ray
run equals a local run episode for episode; the limit on model calls holds across workers;
AI2-THOR workers (over the fake Unity) equal a local run, and a Unity or a worker that dies
costs one re-run, not the episode."""

from __future__ import annotations

import asyncio
import json
import os
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

import pytest

from benchmark_adapter.sim import backends
from benchmark_adapter.sim.thor.pool import ControllerPool
from benchmark_adapter.tasks import load_task, load_tasks
from cocobench_agents.harness import (
    Condition,
    ExecutionSettings,
    InProcess,
    WorkerError,
    plan_episodes,
)
from cocobench_agents.harness.executor import ExecutorStarted
from cocobench_agents.harness.ray_executor import RayExecutor
from cocobench_agents.harness.ray_fleet import fleet_shape, worker_actor_class
from cocobench_agents.harness.ray_limit import ConcurrencyLimiter
from cocobench_agents.harness.ray_local import children_of
from cocobench_agents.harness.ray_session import RayUnavailable, ray_session
from cocobench_agents.harness.ray_worker import WATCH_GROUP
from cocobench_agents.harness.runaway import RunawayLimits
from cocobench_agents.models import ModelPool, ModelSettings
from cocobench_agents.runfolder import RunFolder
from tests.harness.ray_fake_unity import CONTROL_VARIABLE, fake_thor_backend
from tests.paths import SHARED_TASKS

ROOT = Path(__file__).resolve().parents[2]
THOR_TASKS = sorted(SHARED_TASKS.glob("*.json"))[:4]
needs_thor_tasks = pytest.mark.skipif(
    not THOR_TASKS, reason=f"shared CoCoBench task configs not found at {SHARED_TASKS}")
pytestmark = pytest.mark.needs_ray
STALL_S = 3.0  # as short a stall limit as the runaway tests' (--stall-timeout 3)


@pytest.fixture(scope="module")
def control(tmp_path_factory) -> Path:
    """The fake Unity's control folder (see tests/harness/ray_fake_unity.py)."""
    folder = tmp_path_factory.mktemp("fake-unity")
    (folder / "tasks.json").write_text(json.dumps([str(p) for p in THOR_TASKS]))
    return folder


@pytest.fixture(scope="module")
def ray_cluster(control):
    """One private local Ray for the module; afterwards no process of it is left."""
    import ray

    runtime_env = {"env_vars": {"PYTHONPATH": str(ROOT), CONTROL_VARIABLE: str(control)},
                   "worker_process_setup_hook": "tests.harness.ray_fake_unity.install"}
    with ray_session(None, local_cpus=2, local_gpus=1, runtime_env=runtime_env):
        keeper = [pid for pid in children_of(os.getpid()) if _is_keeper(pid)]
        assert len(keeper) == 1
        started = _descendants(keeper[0])
        assert len(started) >= 3  # gcs server, raylet, agents…
        yield ray
    assert not ray.is_initialized()
    _assert_gone([keeper[0], *started])


def _is_keeper(pid: int) -> bool:
    try:
        return b"ray_local" in Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:
        return False


def _descendants(pid: int) -> list[int]:
    out = []
    for child in children_of(pid):
        out += [child, *_descendants(child)]
    return out


def _assert_gone(pids: list[int], timeout_s: float = 20.0) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        alive = [pid for pid in pids if _alive(pid)]
        if not alive:
            return
        time.sleep(0.1)
    raise AssertionError(f"Ray processes left behind: {alive}")


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def demo_plan(**options):
    return plan_episodes(load_tasks("demo"), ["random:7"],
                         [Condition("centralized", "blind"), Condition("decentralized", "blind")],
                         2, **options)


RAY_ONLY = ("elapsed_s", "node", "requeued")  # where and when, not what, an episode ran


def episodes(folder: RunFolder) -> dict[tuple, tuple]:
    """Result lines by episode (without elapsed time, or where a Ray run ran it) and
    trajectory texts; one line each."""
    out = {}
    for record in folder.results():
        key = (record["model"], record["condition"], record["task_id"], record["epoch"])
        assert key not in out, f"{key} recorded twice"
        record = {k: v for k, v in record.items() if k not in RAY_ONLY}
        trajectory = record.get("trajectory")
        out[key] = (record, trajectory and (folder.path / trajectory).read_text())
    return out


def new_folder(path: Path) -> RunFolder:
    folder = RunFolder(path)
    folder.create({"name": path.name})
    return folder


def started(shapes: list[ExecutorStarted]):
    """A handler that keeps what the executor says of its fleet."""
    return lambda event: shapes.append(event) if isinstance(event, ExecutorStarted) else None


def local_run(planned, path: Path, settings: ModelSettings | None = None) -> RunFolder:
    folder = new_folder(path)
    InProcess().run(planned, folder, ModelPool(settings), ExecutionSettings(jobs=4))
    return folder


# -- embedded backend -----------------------------------------------------------------------

@pytest.mark.slow
def test_a_ray_run_equals_a_local_run(ray_cluster, tmp_path):
    planned = demo_plan()
    shapes = []
    folder = new_folder(tmp_path / "ray")
    execution = ExecutionSettings(jobs=4, workers=2)
    RayExecutor().run(planned, folder, ModelPool(ModelSettings()), execution,
                      on_event=started(shapes))
    assert [len(s.capacities) for s in shapes] == [2]
    assert episodes(folder) == episodes(local_run(planned, tmp_path / "local"))
    nodes = {record["node"] for record in folder.results()}
    assert len(nodes) == 1 and len(nodes.pop()) == 56  # the one node's Ray id, in hex
    assert not any("requeued" in record for record in folder.results())
    assert not list(folder.path.glob("**/*.tmp*")), "no temporary file left"


@pytest.mark.slow
def test_a_started_workers_silence_is_its_loops_own(ray_cluster):
    """A worker is asked how it is from the moment it answers `ready`, together with its
    first episode, which may reach its loop after the answer: the silence it reports then is
    its idle loop's, not the time since its start (which had stopped innocent episodes,
    run alone on a fresh worker, as stalled)."""
    worker = worker_actor_class(ray_cluster).options(num_cpus=0.1, max_concurrency=2).remote(
        ModelSettings(), None, "worker-1", "embedded")
    try:
        ray_cluster.get(worker.ready.remote(), timeout=120)
        time.sleep(STALL_S + 1)  # idle, long past its start
        _rss, silent_s = ray_cluster.get(
            worker.health.options(concurrency_group=WATCH_GROUP).remote(), timeout=60)
        assert RunawayLimits(stall_s=STALL_S).breach(grown_bytes=None, in_flight=1,
                                                     silent_s=silent_s) is None, silent_s
    finally:
        ray_cluster.kill(worker)


@pytest.mark.slow
def test_workers_that_cannot_build_the_planner_stop_the_run_before_any_episode(
        ray_cluster, control, tmp_path):
    """A node that lacks a file planner's file, or a package it imports, cannot build it:
    the run stops at start with the workers' error ("Ray workers could not start: …"),
    not with each episode failing. The driver builds the planner (here it may import the
    package); the workers, whose node lacks it (the control file), cannot."""
    strategy = tmp_path / "lab" / "node_planner.py"
    strategy.parent.mkdir()
    guard = (f"import os, pathlib\n"
             f"if (pathlib.Path(os.environ.get({CONTROL_VARIABLE!r}, '/-')) / 'no-planner')"
             f".exists():\n"
             f"    raise ImportError(\"No module named 'lab_only_package'\")\n")
    source = (ROOT / "tests" / "planners" / "user_planner.py").read_text()
    strategy.write_text(source.replace("from __future__ import annotations\n",
                                       "from __future__ import annotations\n" + guard, 1))
    planned = plan_episodes(load_tasks("demo")[:2], ["random:7"],
                            [Condition(f"{strategy}:build_one_node", "blind")], 1)
    folder = new_folder(tmp_path / "no-planner")
    (control / "no-planner").touch()
    try:
        with pytest.raises(WorkerError, match=r"Ray workers could not start: .*"
                                              r"No module named 'lab_only_package'"):
            RayExecutor().run(planned, folder, ModelPool(ModelSettings()),
                              ExecutionSettings(jobs=2, workers=1))
    finally:
        (control / "no-planner").unlink()
    assert list(folder.results()) == []


class CountingServer(ThreadingHTTPServer):
    """An OpenAI-compatible server answering after `delay`; counts calls in flight."""

    daemon_threads = True

    def __init__(self, delay: float) -> None:
        super().__init__(("127.0.0.1", 0), _Handler)
        self.delay, self.lock = delay, threading.Lock()
        self.in_flight = self.peak = self.calls = 0

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.server_address[1]}/v1"


class _Handler(BaseHTTPRequestHandler):
    protocol_version = "HTTP/1.1"

    def log_message(self, *args) -> None:
        pass

    def do_POST(self) -> None:
        server = self.server
        self.rfile.read(int(self.headers["Content-Length"]))
        with server.lock:
            server.in_flight += 1
            server.calls += 1
            server.peak = max(server.peak, server.in_flight)
        time.sleep(server.delay)
        with server.lock:
            server.in_flight -= 1
        body = json.dumps({"id": "x", "object": "chat.completion", "created": 0, "model": "m",
                           "choices": [{"index": 0, "finish_reason": "stop", "message": {
                               "role": "assistant", "content": "ACTION: 1"}}],
                           "usage": {"prompt_tokens": 1, "completion_tokens": 1}}).encode()
        self.send_response(200)
        self.send_header("Content-Type", "application/json")
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        self.wfile.write(body)


@pytest.fixture
def counting_server():
    server = CountingServer(delay=0.1)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield server
    server.shutdown()
    server.server_close()


@pytest.mark.slow
def test_the_limit_on_model_calls_holds_across_workers(ray_cluster, counting_server, tmp_path):
    # Two workers with 4 episodes each in flight: each worker's own semaphore would let 2
    # calls through, 4 in all; the run's limiter lets 2 through across both.
    planned = plan_episodes(load_tasks("demo")[:4], ["openai/m"],
                            [Condition("centralized", "blind"),
                             Condition("decentralized", "blind")], 1, max_steps=3)
    settings = ModelSettings(api_base=counting_server.url, transport="http", max_concurrency=2,
                             timeout_s=10)
    folder = new_folder(tmp_path / "limited")
    execution = ExecutionSettings(jobs=8, workers=2)
    RayExecutor().run(planned, folder, ModelPool(settings), execution)
    records = list(folder.results())
    assert len(records) == len(planned) and not any(r.get("infra_error") for r in records)
    assert counting_server.calls >= len(planned)
    assert counting_server.peak == 2


def test_the_limiter_hands_back_abandoned_and_dead_workers_permits():
    async def scenario():
        limiter = ConcurrencyLimiter(limit=1)
        assert await limiter.acquire("a", "m", "w0")
        waiting = asyncio.create_task(limiter.acquire("b", "m", "w1"))
        await asyncio.sleep(0)
        limiter.release("b")  # its caller gave up before it was granted
        limiter.release("a")
        assert await waiting is False
        assert await limiter.acquire("c", "m", "w2")
        assert limiter.release_holder("w2") == 1  # w2 died holding it
        assert await asyncio.wait_for(limiter.acquire("d", "other", "w3"), 1)
        assert await asyncio.wait_for(limiter.acquire("e", "m", "w3"), 1)
        return limiter.stats()

    assert asyncio.run(scenario()) == {"limit": 1, "peak": {"m": 1, "other": 1},
                                       "in_use": {"m": 1, "other": 1}}


def test_the_fleet_fits_the_cluster():
    cpus4 = {"CPU": 4.0}
    shape = fleet_shape(cpus4, backend="embedded", jobs=10, workers=0, thor_gpus_per_worker=0,
                        episodes=100)
    assert shape.capacities == (3, 3, 2, 2) and shape.num_gpus == 0
    assert fleet_shape(cpus4, backend="embedded", jobs=10, workers=9, thor_gpus_per_worker=0,
                       episodes=3).capacities == (4, 3, 3)
    thor = fleet_shape({"CPU": 16.0, "GPU": 1.0}, backend="ai2thor", jobs=8, workers=0,
                       thor_gpus_per_worker=0.25, episodes=100)
    assert thor.capacities == (1, 1, 1, 1) and thor.num_gpus == 0.25
    assert len(fleet_shape({"CPU": 3.0}, backend="ai2thor", jobs=8, workers=0,
                           thor_gpus_per_worker=0, episodes=100).capacities) == 3
    with pytest.raises(RayUnavailable, match="--thor-gpus-per-worker 0"):
        fleet_shape({"CPU": 16.0}, backend="ai2thor", jobs=8, workers=0,
                    thor_gpus_per_worker=0.25, episodes=10)
    with pytest.raises(RayUnavailable, match="no CPU"):
        fleet_shape({}, backend="embedded", jobs=8, workers=0, thor_gpus_per_worker=0,
                    episodes=10)


# -- AI2-THOR over the fake Unity -----------------------------------------------------------

def thor_plan():
    return plan_episodes([load_task(p) for p in THOR_TASKS], ["random:3"],
                         [Condition("centralized", "blind")], 1,
                         backend="ai2thor", max_steps=6)


@pytest.fixture(scope="module")
def thor_reference(control, tmp_path_factory) -> dict:
    """The thor plan run locally in this process over the fake Unity."""
    pool = ControllerPool(install_exit_hooks=False)
    saved = backends.BACKENDS["ai2thor"]
    backends.BACKENDS["ai2thor"] = fake_thor_backend(control, pool)
    try:
        folder = local_run(thor_plan(), tmp_path_factory.mktemp("thor") / "local")
    finally:
        backends.BACKENDS["ai2thor"] = saved
        pool.close()
    reference = episodes(folder)
    assert not any(r.get("infra_error") for r, _ in reference.values())
    return reference


@pytest.mark.needs_thor
@needs_thor_tasks
@pytest.mark.slow
def test_ai2thor_workers_equal_a_local_run(ray_cluster, thor_reference, tmp_path):
    shapes = []
    folder = new_folder(tmp_path / "thor")
    execution = ExecutionSettings(jobs=8, thor_gpus_per_worker=0.25)
    RayExecutor().run(thor_plan(), folder, ModelPool(ModelSettings()), execution,
                      on_event=started(shapes))
    # One logical GPU at 0.25 each: 4 workers would fit, the 2 CPUs allow 2.
    assert shapes[0].capacities == (1, 1) and "0.25 GPU each" in shapes[0].where
    assert episodes(folder) == thor_reference


@pytest.mark.needs_thor
@needs_thor_tasks
@pytest.mark.slow
def test_a_dead_unity_or_worker_costs_one_rerun_and_a_second_death_an_error(
        ray_cluster, thor_reference, control, tmp_path):
    once, exits, always, _ = (p.key.task_id for p in thor_plan())
    (control / "plan.json").write_text(json.dumps({once: "once", exits: "exit",
                                                   always: "always"}))
    folder = new_folder(tmp_path / "dying")
    try:
        execution = ExecutionSettings(jobs=4, workers=2, thor_gpus_per_worker=0.5)
        RayExecutor().run(thor_plan(), folder, ModelPool(ModelSettings()), execution)
    finally:
        (control / "plan.json").unlink()
    assert {p.name for p in control.iterdir()} >= {f"{once}.once", f"{exits}.exit"}
    got = episodes(folder)
    failed = {key[2]: record for key, (record, _) in got.items() if record.get("infra_error")}
    assert list(failed) == [always]
    assert failed[always]["infra_error"].startswith("ThorCrashed(")
    # The others, the re-run ones included, are as if nothing had happened.
    assert {k: v for k, v in got.items() if k[2] != always} == {
        k: v for k, v in thor_reference.items() if k[2] != always}


@pytest.mark.needs_thor
@needs_thor_tasks
@pytest.mark.slow
def test_workers_on_a_node_without_a_renderer_stop_the_run_before_any_episode(
        ray_cluster, control, tmp_path):
    (control / "no-renderer").touch()
    folder = new_folder(tmp_path / "no-gpu")
    try:
        with pytest.raises(WorkerError, match=r"could not start: .*ThorUnavailable"):
            execution = ExecutionSettings(jobs=2, workers=1, thor_gpus_per_worker=0.5)
            RayExecutor().run(thor_plan(), folder, ModelPool(ModelSettings()), execution)
    finally:
        (control / "no-renderer").unlink()
    assert list(folder.results()) == []
