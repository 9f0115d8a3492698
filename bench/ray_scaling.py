"""Ray executor throughput against the 200 ms fake model server of bench/harness.py.

The same batch (N episodes at --jobs J, every call answered after 200 ms by a server in its
own process) runs with the local executor and with 1, 2 and 4 Ray workers on a private local
Ray started once (its start is printed apart). Each line gives the wall time and its ratio
to the ideal (total model time / J), the Ray workers' start-up (a new process importing the
planner stack, each run) included. Prints medians over --repeats runs.

``--part nodes`` measures the fleet following the cluster instead, on a Ray cluster of
one-CPU nodes on this machine (`ray.cluster_utils`, loopback, token authentication): a
node SIGKILLed once it has run an episode (seconds until its lost episodes run on another
node), and a node added once the run is under way on the head alone (seconds until an episode
starts on it); --jobs 4, the first 16 episodes.

(Named ray_scaling.py, not ray.py: a script's own folder comes first on sys.path, and a
bench/ray.py would shadow the ray package.)

Usage: python bench/ray_scaling.py [--part scaling|nodes] [--episodes 64] [--jobs 32]
       [--max-steps 20] [--workers 1 --workers 2 --workers 4] [--repeats 3]
       [--transport http|litellm]
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from harness import SERVER  # bench/harness.py: the fake OpenAI-compatible server

from benchmark_adapter.tasks import load_tasks
from cocobench_agents.harness import (
    Condition,
    ExecutionSettings,
    InProcess,
    plan_episodes,
)
from cocobench_agents.harness.executor import Bounds, on_recorded
from cocobench_agents.harness.ray_executor import RayExecutor
from cocobench_agents.harness.ray_local import driver_token
from cocobench_agents.harness.ray_session import ray_session, reload_ray_config
from cocobench_agents.models import ModelPool, ModelSettings
from cocobench_agents.runfolder import RunFolder

NODE_JOBS, NODE_EPISODES = 4, 16


def one_run(planned, settings: ModelSettings, jobs: int, workers: int | None
            ) -> tuple[float, int]:
    """(wall s, model calls) of one batch; workers None = the local executor."""
    with tempfile.TemporaryDirectory() as tmp:
        folder = RunFolder(Path(tmp) / "run")
        folder.create({"name": "bench"})
        start = time.perf_counter()
        if workers is None:
            InProcess().run(planned, folder, ModelPool(settings), ExecutionSettings(jobs=jobs))
        else:
            RayExecutor().run(planned, folder, ModelPool(settings),
                              ExecutionSettings(jobs=jobs, workers=workers))
        wall = time.perf_counter() - start
        records = list(folder.results())
    errors = sum(bool(r.get("infra_error")) for r in records)
    if errors or len(records) != len(planned):
        raise SystemExit(f"{errors} episodes failed, {len(records)}/{len(planned)} recorded")
    return wall, sum(r["usage"]["model_calls"] for r in records)


def nodes(planned, settings: ModelSettings, repeats: int) -> None:
    """Seconds from a node's death until its episodes run on another node, and from a node
    joining until it runs an episode (medians, with the range)."""
    # The cluster's nodes inherit these: token authentication with this driver's token, and
    # addresses on loopback (read when Ray is first imported).
    os.environ.update({"RAY_AUTH_MODE": "token", "RAY_AUTH_TOKEN": driver_token(),
                       "RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER": "0"})
    from ray.cluster_utils import Cluster

    reload_ray_config()
    cluster = Cluster(initialize_head=True,
                      head_node_args={"num_cpus": 1, "include_dashboard": False})
    try:
        lost = [_lose_a_node(cluster, planned, settings) for _ in range(repeats)]
        joined = [_add_a_node(cluster, planned, settings) for _ in range(repeats)]
    finally:
        cluster.shutdown()
    print(f"{len(planned)} episodes, --jobs {NODE_JOBS}, one-CPU nodes, median of {repeats}:")
    for label, figures in (("a lost node's episodes run on another node after", lost),
                           ("a node that joins starts its first episode after", joined)):
        print(f"  {label} {statistics.median(figures):.1f} s (range {min(figures):.1f}–"
              f"{max(figures):.1f} s; load average {os.getloadavg()[0]:.1f})")


def _lose_a_node(cluster, planned, settings: ModelSettings) -> float:
    """Kill a node (SIGKILL of its raylet and workers) once it has run an episode; seconds
    until the last of its episodes started on the head."""
    node = cluster.add_node(num_cpus=1)
    killed: list[float] = []
    rerun: list[float] = []

    def on_result(record: dict) -> None:
        now = time.perf_counter()
        if record["node"] == node.node_id and not killed:
            cluster.remove_node(node, allow_graceful=False)
            killed.append(time.perf_counter())
        elif record.get("requeued"):
            rerun.append(now - record["elapsed_s"])  # when it started, on the worker's clock

    _run_on(cluster, planned, settings, on_result)
    _wait_until_gone(cluster, node.node_id)
    return max(rerun) - killed[0]


def _add_a_node(cluster, planned, settings: ModelSettings) -> float:
    """Add a node once the run has recorded an episode on the head alone; seconds until an
    episode starts on it (the run stops dispatching then)."""
    joined: list[tuple[object, float]] = []
    first: list[float] = []

    class FirstEpisodeThere:  # stands in for the spend limit
        def reached(self) -> bool:
            return bool(first)

    def on_result(record: dict) -> None:
        now = time.perf_counter()
        if not joined:
            # Cluster.add_node returns once Ray has registered the node.
            joined.append((cluster.add_node(num_cpus=1), time.perf_counter()))
        elif record["node"] == joined[0][0].node_id and not first:
            first.append(now - record["elapsed_s"])

    _run_on(cluster, planned * 15, settings, on_result, limit=FirstEpisodeThere())
    node, added = joined[0]
    cluster.remove_node(node)
    _wait_until_gone(cluster, node.node_id)
    return first[0] - added


def _run_on(cluster, planned, settings: ModelSettings, on_result, limit=None) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        folder = RunFolder(Path(tmp) / "run")
        folder.create({"name": "bench"})
        execution = ExecutionSettings(executor="ray", jobs=NODE_JOBS,
                                      ray_address=cluster.address)
        RayExecutor().run(planned, folder, ModelPool(settings), execution,
                          bounds=Bounds(spend=limit), on_event=on_recorded(on_result))


def _wait_until_gone(cluster, node_id: str) -> None:
    # Ray declares a killed node dead after its health checks fail (about 15 s); a node it
    # still counts would enlarge the next run's first fleet.
    while any(n["NodeID"] == node_id and n["Alive"] for n in cluster.global_state.node_table()):
        time.sleep(0.2)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--part", default="scaling", choices=["scaling", "nodes"])
    parser.add_argument("--episodes", type=int, default=64)
    parser.add_argument("--jobs", type=int, default=32)
    parser.add_argument("--max-steps", type=int, default=20)
    parser.add_argument("--delay", type=float, default=0.2)
    parser.add_argument("--workers", type=int, action="append")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--transport", default="http", choices=["http", "litellm"])
    args = parser.parse_args()
    worker_counts = args.workers or [1, 2, 4]
    server = subprocess.Popen([sys.executable, "-c", SERVER, str(args.delay)],
                              stdout=subprocess.PIPE, text=True)
    try:
        url = server.stdout.readline().strip()
        planned = plan_episodes(load_tasks("cocobench-240")[:args.episodes], ["openai/bench"],
                                [Condition("centralized", "blind")], 1,
                                max_steps=args.max_steps)
        settings = ModelSettings(api_base=url, max_concurrency=args.jobs, timeout_s=30,
                                 transport=args.transport)
        ModelPool(settings).validate("openai/bench")
        if args.part == "nodes":
            nodes(planned[:NODE_EPISODES], settings, args.repeats)
            return
        print(f"{len(planned)} episodes, --jobs {args.jobs}, calls of {args.delay * 1e3:.0f} ms"
              f" (--transport {args.transport}), median of {args.repeats}:")
        report("local executor", [one_run(planned, settings, args.jobs, None)
                                  for _ in range(args.repeats)], args)
        started = time.perf_counter()
        with ray_session(None, local_cpus=max(worker_counts)):
            print(f"  (local Ray started in {time.perf_counter() - started:.1f} s, "
                  f"{max(worker_counts)} logical CPUs)")
            for workers in worker_counts:
                report(f"Ray, {workers} worker{'s' if workers > 1 else ''}",
                       [one_run(planned, settings, args.jobs, workers)
                        for _ in range(args.repeats)], args)
    finally:
        server.kill()


def report(label: str, runs: list[tuple[float, int]], args) -> None:
    wall = statistics.median(r[0] for r in runs)
    calls = runs[0][1]
    ideal = calls * args.delay / args.jobs
    print(f"  {label:18s} {wall:6.1f} s = {wall / ideal:4.2f}x ideal ({ideal:.1f} s for "
          f"{calls} calls; load average {os.getloadavg()[0]:.1f})")


if __name__ == "__main__":
    main()
