"""The Inspect door's overhead: the same episodes through `inspect eval` (mockllm fed a fixed
list of replies) and through `cocobench run` (``scripted:`` fed the same list), one episode at
a time, on the 240 instances' first N under C0_blind and D1_blind.

Prints the median wall time per episode of each door and per decision of the Inspect door
(Inspect's sample machinery, transcript and log writing on top of our runner). Needs the
inspect extra.

Usage: python bench/inspect_task.py [--instances 8] [--repeats 3]
"""

from __future__ import annotations

import argparse
import json
import statistics
import tempfile
import time
from pathlib import Path

from inspect_ai import eval as inspect_eval
from inspect_ai.model import ModelOutput, ModelUsage, get_model

from benchmark_adapter.tasks import load_tasks
from cocobench_agents.api import evaluate
from cocobench_agents.inspect_eval import cocobench

REPLIES = ["ACTION: 3", "ACTION: 1", "ACTION: 0", "ACTION: 2", "ACTION: 5", "ACTION: 1",
           "ACTION: 4", "ACTION: 0", "ACTION: 3", "ACTION: 2", "I am not sure."]
CONDITIONS = "C0_blind,D1_blind"


def mockllm():
    """mockllm replaying REPLIES from the start for every sample (as scripted: does)."""
    from inspect_ai.log._samples import sample_active

    cursors: dict[tuple[object, int], int] = {}

    def output(*_):
        active = sample_active()
        key = (active.sample.id, active.epoch)
        index = cursors[key] = cursors.get(key, -1) + 1
        reply = ModelOutput.from_content("mockllm/model",
                                         REPLIES[index] if index < len(REPLIES) else
                                         "ACTION: DONE")
        reply.usage = ModelUsage(input_tokens=1, output_tokens=1, total_tokens=2)
        return reply

    return get_model("mockllm/model", custom_outputs=output, memoize=False)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--instances", type=int, default=8)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    ids = [t.task_id for t in load_tasks("cocobench-240")[:args.instances]]
    ours, theirs, per_decision = [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        script = Path(tmp) / "replies.json"
        script.write_text(json.dumps(REPLIES))
        for repeat in range(args.repeats):
            started = time.perf_counter()
            results = evaluate("cocobench-240", models=f"scripted:{script}",
                               out=Path(tmp) / f"run{repeat}", conditions=CONDITIONS,
                               task_id=ids, jobs=1)
            ours.append((time.perf_counter() - started) / len(results))
            started = time.perf_counter()
            [log] = inspect_eval(cocobench(task="cocobench-240", conditions=CONDITIONS,
                                           task_id=ids),
                                 model=mockllm(), model_roles={f"agent_{i}": mockllm()
                                                               for i in (1, 2, 3, 4)},
                                 log_dir=str(Path(tmp) / "logs"), display="none",
                                 max_samples=1)
            elapsed = time.perf_counter() - started
            theirs.append(elapsed / len(log.samples))
            calls = sum(1 for s in log.samples for e in s.events if e.event == "model")
            per_decision.append(elapsed / calls)
    print(f"{len(ids)} instances x {CONDITIONS}, {args.repeats} repeats, one episode at a time")
    print(f"cocobench run:  {statistics.median(ours) * 1000:8.1f} ms per episode (median)")
    print(f"inspect eval:   {statistics.median(theirs) * 1000:8.1f} ms per episode (median)")
    print(f"inspect eval:   {statistics.median(per_decision) * 1000:8.1f} ms per decision")
    print(f"ratio:          {statistics.median(theirs) / statistics.median(ours):8.2f}x")


if __name__ == "__main__":
    main()
