"""Harness performance: per-decision overhead, throughput against a 200 ms model server, and
memory over a full-suite run.

Prints medians and ratios:
1. overhead per planner decision (the planner's loop, prompt, parse, simulator step,
   recording, scoring) with the zero-latency `greedy` built-in, C0 and D1, wall and CPU (aim:
   median <= 0.5 ms, issue 39). The built-ins' rounds are awaited directly
   (`graphs/rounds.py`), not through LangGraph: CPU per decision C0 2.50-3.42 -> 0.72-0.92
   ms, D1 1.93-2.07 -> 0.67-0.99 ms, measured alternately at a load of 12-14 on 2 cores
   (docs/contributing.md says where the rest goes);
2. N episodes (each to its own step budget) at --jobs 64 against a local OpenAI-compatible
   server (a separate process) that answers every call after a fixed 200 ms: wall time vs
   the ideal (total model time / 64) (aim: <= 1.25x), for each model transport (LiteLLM, the
   lean http client) in one process and in worker processes;
3. peak RSS of a whole `cocobench-full` run with `greedy` (aim: < 1 GB);
4. the cost per model call of the tenacity `RetryPolicy` the decide node applies, on the
   success path (against the 2 ms per-decision budget).

Usage: python bench/harness.py [--part overhead|throughput|memory|retry|all] [--episodes 240]
       [--transport litellm|http]… [--workers N]…
"""

from __future__ import annotations

import argparse
import asyncio
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

from benchmark_adapter.tasks import load_tasks
from cocobench_agents.episode_runner import EpisodeSpec, run_episode
from cocobench_agents.harness import (
    Condition,
    ExecutionSettings,
    InProcess,
    WorkerProcesses,
    plan_episodes,
)
from cocobench_agents.models import (
    TRANSPORTS,
    ModelPool,
    ModelReply,
    ModelRequest,
    ModelSettings,
    RetryPolicy,
)
from cocobench_agents.runfolder import RunFolder

SERVER = textwrap.dedent('''
    import json, re, sys, time
    from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
    DELAY = float(sys.argv[1])
    class Handler(BaseHTTPRequestHandler):
        protocol_version = "HTTP/1.1"
        # Headers and body go out as two writes: with Nagle on, the body waits for the
        # client's delayed ACK (40 ms), which would be charged to the harness.
        disable_nagle_algorithm = True
        def log_message(self, *args): pass
        def do_POST(self):
            body = json.loads(self.rfile.read(int(self.headers["Content-Length"])))
            prompt = body["messages"][-1]["content"]
            prompt = prompt if isinstance(prompt, str) else prompt[0]["text"]
            # Explore forward: a legal action that keeps the episode going to its budget.
            ids = re.findall(r"^  (\\d+): agent_\\d+: explore forward", prompt, re.M)
            time.sleep(DELAY)
            text = f"REASON: look around\\nACTION: {ids[0] if ids else 'DONE'}"
            data = json.dumps({"id": "x", "object": "chat.completion", "created": 0,
                "model": "bench", "choices": [{"index": 0, "finish_reason": "stop",
                "message": {"role": "assistant", "content": text}}],
                "usage": {"prompt_tokens": 100, "completion_tokens": 10,
                          "total_tokens": 110}}).encode()
            self.send_response(200)
            self.send_header("Content-Type", "application/json")
            self.send_header("Content-Length", str(len(data)))
            self.end_headers()
            self.wfile.write(data)
    ThreadingHTTPServer.request_queue_size = 256
    server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    print(f"http://127.0.0.1:{server.server_address[1]}/v1", flush=True)
    server.serve_forever()
''')


def overhead(configs) -> None:
    """Time per decision of whole episodes with a zero-latency model: wall, and this
    process's CPU time (which the load of a shared machine distorts less)."""
    pool = ModelPool()

    async def timed(planner: str) -> tuple[list[float], list[float]]:
        # One event loop for all episodes, as a run's batch has: `asyncio.run` per episode
        # would charge each episode its signal-handler restore, which formats the finished
        # task's repr, the whole trajectory document in it (4-5 % of the CPU).
        wall, cpu = [], []
        for config in configs:
            spec = EpisodeSpec(config, planner=planner, obs_mode="blind",
                               models={"*": "greedy"})
            start, start_cpu = time.perf_counter(), time.process_time()
            document, _ = await run_episode(spec, pool)
            decisions = len(document["planner_decisions"])
            wall.append((time.perf_counter() - start) / decisions)
            cpu.append((time.process_time() - start_cpu) / decisions)
        return wall, cpu

    for planner in ("centralized", "decentralized-broadcast"):
        wall, cpu = asyncio.run(timed(planner))
        print(f"overhead per decision, {planner:24s} median {statistics.median(wall) * 1e3:5.2f}"
              f" ms (p90 {sorted(wall)[int(0.9 * len(wall))] * 1e3:.2f} ms), CPU "
              f"{statistics.median(cpu) * 1e3:.2f} ms; {len(wall)} episodes, load "
              f"{os.getloadavg()[0]:.1f} (aim <= 0.5 ms)")


def throughput(configs, episodes: int, jobs: int, delay: float, max_steps: int,
               transport: str, workers: int) -> None:
    """Wall time of a batch against a slow server, vs total model time / jobs."""
    server = subprocess.Popen([sys.executable, "-c", SERVER, str(delay)],
                              stdout=subprocess.PIPE, text=True)
    try:
        url = server.stdout.readline().strip()
        tasks = configs[:episodes]
        planned = plan_episodes(tasks, ["openai/bench"], [Condition("centralized", "blind")], 1,
                                max_steps=max_steps)
        settings = ModelSettings(api_base=url, max_concurrency=jobs, timeout_s=30,
                                 transport=transport)
        pool = ModelPool(settings)
        pool.validate("openai/bench")  # as `cocobench run` does: imports LiteLLM up front
        with tempfile.TemporaryDirectory() as tmp:
            folder = RunFolder(Path(tmp) / "run")
            folder.create({"name": "bench"})
            start, cpu = time.perf_counter(), _cpu_s()
            if workers > 1:
                WorkerProcesses().run(planned, folder, pool,
                                      ExecutionSettings(jobs=jobs, workers=workers))
            else:
                InProcess().run(planned, folder, pool, ExecutionSettings(jobs=jobs))
            wall, cpu = time.perf_counter() - start, _cpu_s() - cpu
            calls = sum(r["usage"]["model_calls"] for r in folder.results())
        ideal = calls * delay / jobs
        print(f"throughput, --transport {transport:7s} --workers {workers}: {len(planned)} "
              f"episodes, {calls} calls of {delay * 1e3:.0f} ms at --jobs {jobs}: {wall:.1f} s "
              f"vs ideal {ideal:.1f} s = {wall / ideal:.2f}x (aim <= 1.25x); CPU per call: "
              f"harness {cpu / calls * 1e3:.1f} ms, "
              f"server {_server_cpu_s(server.pid) / calls * 1e3:.1f} ms")
    finally:
        server.kill()


def _cpu_s() -> float:
    """CPU seconds of this process and its ended worker processes (not the server: it is
    killed, never waited for, so it is not counted among the children)."""
    own, children = (resource.getrusage(who) for who in
                     (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN))
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def _server_cpu_s(pid: int) -> float:
    """CPU seconds the server process has used so far (Linux; 0 elsewhere)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return 0.0
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def memory(suite: str) -> None:
    """Peak RSS of a whole run, measured in a child process."""
    with tempfile.TemporaryDirectory() as tmp:
        command = [sys.executable, "-m", "cocobench_agents.cli", "run", "--suite", suite,
                   "--model", "greedy", "--out", f"{tmp}/run", "--jobs", "8"]
        start = time.perf_counter()
        subprocess.run(command, check=True, capture_output=True)
        wall = time.perf_counter() - start
        peak_mb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
        lines = len(Path(f"{tmp}/run/results.jsonl").read_text().splitlines())
    print(f"memory: {lines}-episode {suite} run, peak RSS {peak_mb:.0f} MB (aim < 1024 MB), "
          f"{wall:.0f} s")


def retry_overhead(calls: int = 2000, repeats: int = 15) -> None:
    """Per-call time of `RetryPolicy.complete` minus that of the bare attempt it wraps."""

    class Instant:
        name = "instant"
        reply = ModelReply(text="ACTION: 1")

        async def attempt(self, request, number):
            return self.reply

    client, policy, request = Instant(), RetryPolicy(), ModelRequest(prompt="p")

    async def timed(call) -> float:
        start = time.perf_counter()
        for _ in range(calls):
            await call()
        return (time.perf_counter() - start) / calls

    async def measure() -> list[float]:
        bare = await timed(lambda: client.attempt(request, 1))
        wrapped = await timed(lambda: policy.complete(client, request))
        return [wrapped - bare]

    costs = [asyncio.run(measure())[0] for _ in range(repeats)]
    print(f"retry policy (tenacity) per model call: median {statistics.median(costs) * 1e6:.0f} us"
          f" (min {min(costs) * 1e6:.0f}, max {max(costs) * 1e6:.0f}; {repeats} x {calls} calls;"
          f" budget 2 ms per decision)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--part", default="all",
                        choices=["overhead", "throughput", "memory", "retry", "all"])
    parser.add_argument("--episodes", type=int, default=240)
    parser.add_argument("--jobs", type=int, default=64)
    parser.add_argument("--delay", type=float, default=0.2)
    parser.add_argument("--max-steps", type=int, default=None,
                        help="Cap every episode's step budget (default: each instance's own).")
    parser.add_argument("--transport", action="append", choices=TRANSPORTS,
                        help="Model transport(s) to measure (default: both).")
    parser.add_argument("--workers", action="append", type=int,
                        help="Worker processes to measure with (default: 1 and 2).")
    args = parser.parse_args()
    args.transport = args.transport or list(TRANSPORTS)
    args.workers = args.workers or [1, 2]
    configs = load_tasks("cocobench-240")
    if args.part in ("retry", "all"):
        retry_overhead()
    if args.part in ("overhead", "all"):
        overhead(configs[::4])
    if args.part in ("throughput", "all"):
        for transport in args.transport:
            for workers in args.workers:
                throughput(configs, args.episodes, args.jobs, args.delay, args.max_steps,
                           transport, workers)
    if args.part in ("memory", "all"):
        memory("cocobench-full")


if __name__ == "__main__":
    main()
