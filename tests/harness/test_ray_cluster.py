"""The Ray executor on a real multi-node Ray: a head and worker nodes, each its own raylet
(`ray.cluster_utils.Cluster`, one CPU each, token authentication, on 127.0.0.1), joined by
address as ``--ray-address`` does. A node lost mid-run costs its episodes one re-run each on
another node and the run still equals a local one; a node that joins mid-run gets episodes; a
node without the run's key stops the run before any episode; a fatal model error stops the
dispatch; an AI2-THOR worker's lost GPU node has its episode re-run on another GPU node.

The model is the fake OpenAI server answering after a small delay. Nothing sleeps for a fixed
time: the tests act on results as the executor records them (or on the fake Unity's marker
files), and every run is bounded (`within`)."""

from __future__ import annotations

import contextlib
import json
import os
import signal
import threading
import time
from collections import Counter
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from benchmark_adapter.sim import backends
from benchmark_adapter.sim.thor.pool import ControllerPool
from benchmark_adapter.tasks import load_task, load_tasks
from cocobench_agents.harness import (
    Condition,
    ExecutionSettings,
    InProcess,
    plan_episodes,
)
from cocobench_agents.harness.errors import FatalModelError, WorkerEnvironmentError, WorkersLost
from cocobench_agents.harness.executor import Bounds, on_recorded
from cocobench_agents.harness.ray_executor import RayExecutor
from cocobench_agents.harness.ray_local import driver_token
from cocobench_agents.harness.ray_session import reload_ray_config
from cocobench_agents.models import ModelPool, ModelSettings
from cocobench_agents.runfolder import RunFolder
from cocobench_agents.runfolder.summary import node_lines
from tests.harness.ray_fake_unity import CONTROL_VARIABLE, fake_thor_backend
from tests.models.fake_openai import FakeOpenAI, error, ok
from tests.paths import SHARED_TASKS

ROOT = Path(__file__).resolve().parents[2]
KEY = "COCOBENCH_TEST_CLUSTER_KEY"  # the run's key variable (`api_key_env`); no real key
DELAY_S = 0.1  # the model's answer time
BOUND_S = 240  # no run of this module may take longer (2 busy cores)
STRANDED_WAIT_S = 20  # the stranded run's --ray-wait
NODE_GONE_S = 60  # Ray declares a killed node dead after about 15 s (its health checks)
NOT_COMPARED = ("elapsed_s", "latency_s", "model_latency_s",  # timing
                "node", "requeued")  # where a Ray run ran an episode
THOR_TASKS = sorted(SHARED_TASKS.glob("*.json"))[:4]
needs_thor_tasks = pytest.mark.skipif(
    not THOR_TASKS, reason=f"shared CoCoBench task configs not found at {SHARED_TASKS}")
pytestmark = pytest.mark.needs_ray


@contextlib.contextmanager
def within(seconds: float) -> Iterator[None]:
    """Fail (TimeoutError, raised in the driver's loop within its half-second wake-up) if
    the block takes longer than `seconds`: a hung run must fail the test, not stall CI."""
    def expire(signum: int, frame: object) -> None:
        raise TimeoutError(f"the run did not finish within {seconds} s")

    previous = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


@pytest.fixture(scope="module")
def cluster():
    """A head node (1 CPU, no GPU) for the module; tests add and remove worker nodes."""
    from ray.cluster_utils import Cluster

    # The nodes inherit this environment: token authentication, with this process's token
    # (Ray keeps the first token a process reads; see ray_local), and the run's key.
    variables = {"RAY_AUTH_MODE": "token", "RAY_AUTH_TOKEN": driver_token(), KEY: "not-a-secret"}
    saved = {name: os.environ.get(name) for name in variables}
    os.environ.update(variables)
    reload_ray_config()  # this process may have read Ray's authentication mode before
    cluster = Cluster(initialize_head=True, head_node_args={
        "num_cpus": 1, "num_gpus": 0, "include_dashboard": False})
    try:
        yield cluster
    finally:
        cluster.shutdown()
        for name, value in saved.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value


@contextlib.contextmanager
def extra_node(cluster, **resources: Any) -> Iterator[Any]:
    """A worker node for one test: removed afterwards, and gone from Ray's view (a node Ray
    still counts would make the next test's fleet larger than the cluster)."""
    node = cluster.add_node(num_cpus=1, **resources)
    try:
        yield node
    finally:
        if node in cluster.worker_nodes:
            cluster.remove_node(node)
        deadline = time.monotonic() + NODE_GONE_S
        while any(n["NodeID"] == node.node_id and n["Alive"]
                  for n in cluster.global_state.node_table()):
            assert time.monotonic() < deadline, f"Ray still counts node {node.node_id}"
            time.sleep(0.2)


@pytest.fixture(scope="module")
def server():
    with FakeOpenAI(ok(delay_s=DELAY_S)) as fake:
        yield fake


def settings(server: FakeOpenAI) -> ModelSettings:
    return ModelSettings(api_base=server.base_url, transport="http", timeout_s=30,
                         api_key_env=KEY)


def plan(count: int = 16):
    return plan_episodes(load_tasks("cocobench-240")[:count], ["openai/fake"],
                         [Condition("centralized", "blind")], 1, max_steps=4)


def new_folder(path: Path) -> RunFolder:
    folder = RunFolder(path)
    folder.create({"name": path.name})
    return folder


def _scrub(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _scrub(v) for k, v in value.items() if k not in NOT_COMPARED}
    if isinstance(value, list):
        return [_scrub(v) for v in value]
    return value


def comparable(folder: RunFolder) -> dict[tuple, tuple]:
    """Result lines and trajectories by episode, without timing or where they ran; fails
    if an episode is recorded twice."""
    out = {}
    for record in folder.results():
        key = (record["model"], record["condition"], record["task_id"], record["epoch"])
        assert key not in out, f"{key} recorded twice"
        trajectory = json.loads((folder.path / record["trajectory"]).read_text())
        out[key] = (_scrub(record), _scrub(trajectory))
    return out


def differences(got: Any, expected: Any, where: str = "") -> list[str]:
    """Where two JSON values differ (the first few paths), for a readable failure."""
    if isinstance(got, dict) and isinstance(expected, dict):
        keys = list(dict.fromkeys([*got, *expected]))
        return [d for k in keys for d in differences(got.get(k), expected.get(k),
                                                     f"{where}/{k}")][:10]
    if isinstance(got, (list, tuple)) and isinstance(expected, (list, tuple)) and len(
            got) == len(expected):
        return [d for i, (g, e) in enumerate(zip(got, expected))
                for d in differences(g, e, f"{where}[{i}]")][:10]
    return [] if got == expected else [f"{where}: {got!r:.80} != {expected!r:.80}"]


@pytest.fixture(scope="module")
def reference(server, tmp_path_factory) -> dict[tuple, tuple]:
    """The plan run locally, in this process."""
    server.program(default=ok(delay_s=DELAY_S))
    folder = new_folder(tmp_path_factory.mktemp("local") / "run")
    InProcess().run(plan(), folder, ModelPool(settings(server)), ExecutionSettings(jobs=4))
    return comparable(folder)


# -- embedded backend -----------------------------------------------------------------------

@pytest.mark.slow
def test_a_node_lost_mid_run_costs_its_episodes_one_rerun_elsewhere(
        cluster, server, reference, tmp_path):
    server.program(default=ok(delay_s=DELAY_S))
    head = cluster.head_node.node_id
    folder = new_folder(tmp_path / "ray")
    with extra_node(cluster) as lost:
        killed: list[float] = []

        def on_result(record: dict[str, Any]) -> None:
            # Once the node has run an episode, it dies with others in flight or on their way.
            if record["node"] == lost.node_id and not killed:
                cluster.remove_node(lost, allow_graceful=False)  # SIGKILL, as a lost machine
                killed.append(time.monotonic())

        with within(BOUND_S):
            execution = ExecutionSettings(executor="ray", jobs=4, ray_address=cluster.address)
            RayExecutor().run(plan(), folder, ModelPool(settings(server)), execution,
                              on_event=on_recorded(on_result))
    assert killed
    got = comparable(folder)  # each episode once, as a local run records it
    assert got == reference, differences({str(k): v for k, v in got.items()},
                                         {str(k): v for k, v in reference.items()})
    records = list(folder.results())
    requeued = [r for r in records if "requeued" in r]
    assert requeued and all(r["requeued"] == 1 and r["node"] == head for r in requeued)
    assert {r["node"] for r in records} == {head, lost.node_id}
    lines = node_lines(records)
    assert lines[0].startswith(f"node {head}: ") and f"{len(requeued)} of them re-queued" in (
        lines[0])


@pytest.mark.slow
def test_a_node_that_joins_mid_run_gets_episodes(cluster, server, tmp_path):
    server.program(default=ok(delay_s=DELAY_S))
    head = cluster.head_node.node_id
    folder = new_folder(tmp_path / "growing")
    joined: list[Any] = []
    enough = threading.Event()

    class UntilTheNewNodeRanOne:
        """Stands in for the spend limit: no episode starts once the new node has run one."""

        def reached(self) -> bool:
            return enough.is_set()

    with contextlib.ExitStack() as nodes:
        def on_result(record: dict[str, Any]) -> None:
            if not joined:  # the run is under way on the head alone: a node joins
                joined.append(nodes.enter_context(extra_node(cluster)))
            elif record["node"] == joined[0].node_id:
                enough.set()

        with within(BOUND_S):
            execution = ExecutionSettings(executor="ray", jobs=4, ray_address=cluster.address)
            RayExecutor().run(plan(240), folder, ModelPool(settings(server)), execution,
                              bounds=Bounds(spend=UntilTheNewNodeRanOne()),  # type: ignore[arg-type]
                              on_event=on_recorded(on_result))
    assert enough.is_set()
    records = list(folder.results())
    assert len({(r["task_id"], r["epoch"]) for r in records}) == len(records)
    assert not any(r.get("infra_error") or r.get("requeued") for r in records)
    ran = Counter(record["node"] for record in records)
    assert set(ran) == {head, joined[0].node_id} and ran[head] >= 1


@pytest.mark.slow
def test_a_node_without_the_runs_key_stops_the_run_before_any_episode(
        cluster, server, tmp_path, monkeypatch):
    server.program(default=ok(delay_s=DELAY_S))
    folder = new_folder(tmp_path / "no-key")
    with contextlib.ExitStack() as nodes:
        with monkeypatch.context() as environment:
            environment.delenv(KEY)  # the node is started without it (the driver has it)
            bare = nodes.enter_context(extra_node(cluster))
        with within(BOUND_S), pytest.raises(WorkerEnvironmentError) as stopped:
            execution = ExecutionSettings(executor="ray", jobs=4, ray_address=cluster.address)
            RayExecutor().run(plan(), folder, ModelPool(settings(server)), execution)
    assert (stopped.value.variables, stopped.value.node) == ((KEY,), bare.node_id)
    message = str(stopped.value)
    assert KEY in message and bare.node_id in message and "docs/distributed.md" in message
    assert "not-a-secret" not in message
    assert list(folder.results()) == [] and server.count == 0


@pytest.mark.slow
def test_a_node_without_the_key_that_joins_mid_run_stops_the_dispatch(
        cluster, server, tmp_path, monkeypatch):
    server.program(default=ok(delay_s=DELAY_S))
    folder = new_folder(tmp_path / "bad-joiner")
    joined: list[Any] = []
    with contextlib.ExitStack() as nodes:
        def on_result(record: dict[str, Any]) -> None:
            if not joined:
                with monkeypatch.context() as environment:
                    environment.delenv(KEY)
                    joined.append(nodes.enter_context(extra_node(cluster)))

        with within(BOUND_S), pytest.raises(WorkerEnvironmentError) as stopped:
            execution = ExecutionSettings(executor="ray", jobs=4, ray_address=cluster.address)
            RayExecutor().run(plan(240), folder, ModelPool(settings(server)), execution,
                              on_event=on_recorded(on_result))
    assert stopped.value.node == joined[0].node_id
    records = list(folder.results())  # what was in flight finished and is recorded
    assert 1 < len(records) < 240
    assert {r["node"] for r in records} == {cluster.head_node.node_id}


@pytest.mark.slow
def test_a_run_with_no_worker_alive_for_wait_s_stops_with_what_finished_recorded(
        cluster, server, tmp_path):
    import ray

    server.program(default=ok(delay_s=DELAY_S))
    folder = new_folder(tmp_path / "stranded")
    ray.init(address=cluster.address, log_to_driver=False)  # the run uses this connection
    try:
        # The head's one CPU is taken: the run's one worker goes to the other node, and
        # once that node is lost nothing can take its place.
        blocker = ray.remote(num_cpus=1)(Blocker).remote()
        ray.get(blocker.ready.remote())
        with extra_node(cluster) as lost:
            def on_result(record: dict[str, Any]) -> None:
                if lost in cluster.worker_nodes:
                    cluster.remove_node(lost, allow_graceful=False)

            # Long enough for the worker to start on a busy machine: its start counts as a
            # time with no worker alive (a 3 s wait ran out first on CI's two loaded cores).
            with within(BOUND_S), pytest.raises(WorkersLost) as stopped:
                execution = ExecutionSettings(executor="ray", jobs=4, ray_address=cluster.address,
                                              ray_wait=STRANDED_WAIT_S)
                RayExecutor().run(plan(), folder, ModelPool(settings(server)), execution,
                                  on_event=on_recorded(on_result))
    finally:
        ray.shutdown()
    assert stopped.value.cause.startswith("the nodes that ran them are gone"), stopped.value
    records = list(folder.results())
    assert records and {r["node"] for r in records} == {lost.node_id}
    assert len(records) + stopped.value.left == len(plan())
    assert "--ray-wait" in str(stopped.value) and "--resume" in str(stopped.value)


class Blocker:
    """Holds a CPU of the node it is placed on."""

    def ready(self) -> bool:
        return True


@pytest.mark.slow
def test_a_fatal_model_error_stops_the_dispatch_on_ray(cluster, server, tmp_path):
    server.program(default=error(401, "Incorrect API key provided"))
    folder = new_folder(tmp_path / "refused")
    with within(BOUND_S), pytest.raises(FatalModelError) as stopped:
        execution = ExecutionSettings(executor="ray", jobs=4, ray_address=cluster.address)
        RayExecutor().run(plan(), folder, ModelPool(settings(server)), execution)
    assert (stopped.value.model, stopped.value.kind) == ("openai/fake", "auth")
    records = list(folder.results())
    assert 1 <= len(records) <= 4  # those in flight when the first one came back
    assert all(r["backend_errors"] and r["node"] == cluster.head_node.node_id for r in records)


# -- AI2-THOR over the fake Unity -----------------------------------------------------------

def thor_plan():
    return plan_episodes([load_task(p) for p in THOR_TASKS], ["random:3"],
                         [Condition("centralized", "blind")], 1,
                         backend="ai2thor", max_steps=6)


@pytest.fixture(scope="module")
def control(tmp_path_factory) -> Path:
    """The fake Unity's control folder (see tests/harness/ray_fake_unity.py)."""
    folder = tmp_path_factory.mktemp("fake-unity")
    (folder / "tasks.json").write_text(json.dumps([str(p) for p in THOR_TASKS]))
    return folder


@pytest.mark.needs_thor
@needs_thor_tasks
@pytest.mark.slow
def test_a_lost_gpu_nodes_episode_reruns_on_another(cluster, control, tmp_path):
    pool = ControllerPool(install_exit_hooks=False)
    saved = backends.BACKENDS["ai2thor"]
    backends.BACKENDS["ai2thor"] = fake_thor_backend(control, pool)
    try:
        local = new_folder(tmp_path / "local")
        InProcess().run(thor_plan(), local, ModelPool(), ExecutionSettings(jobs=2))
    finally:
        backends.BACKENDS["ai2thor"] = saved
        pool.close()
    held = thor_plan()[0].key.task_id
    (control / "plan.json").write_text(json.dumps({held: "hold"}))  # its first run hangs
    runtime_env = {"env_vars": {"PYTHONPATH": str(ROOT), CONTROL_VARIABLE: str(control)},
                   "worker_process_setup_hook": "tests.harness.ray_fake_unity.install"}
    folder = new_folder(tmp_path / "ray")
    with extra_node(cluster, num_gpus=1) as first, extra_node(cluster, num_gpus=1) as second:
        nodes = {node.node_id: node for node in (first, second)}
        killed: list[str] = []

        def kill_the_holding_node() -> None:
            marker = control / f"{held}.held"
            deadline = time.monotonic() + BOUND_S
            while not marker.exists() or not marker.read_text():
                if time.monotonic() > deadline:
                    return
                time.sleep(0.05)
            killed.append(marker.read_text())
            cluster.remove_node(nodes[killed[0]], allow_graceful=False)

        watcher = threading.Thread(target=kill_the_holding_node, daemon=True)
        watcher.start()
        try:
            with within(BOUND_S):
                execution = ExecutionSettings(executor="ray", jobs=2, ray_address=cluster.address,
                                              thor_gpus_per_worker=1)
                thor = RayExecutor(runtime_env=runtime_env)
                thor.run(thor_plan(), folder, ModelPool(ModelSettings()), execution)
        finally:
            watcher.join(timeout=BOUND_S)
            (control / "plan.json").unlink()
    assert killed
    assert comparable(folder) == comparable(local)
    (record,) = [r for r in folder.results() if r["task_id"] == held]
    assert record["requeued"] == 1 and record["node"] in set(nodes) - set(killed)
