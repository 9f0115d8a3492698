"""A training script exits cleanly: one that imports torch and makes environments of every
kind (parallel, AEC, a seat; blind and image; Gymnasium's sync and async vectors), some
closed, some left open mid-episode, prints nothing on stderr at exit. Before, every such
script ended with "Exception ignored in: <function CoCoBenchParallelEnv.__del__ …>
AttributeError: 'NoneType' object has no attribute 'EVENT_READ'" (a `__del__` that closed
the event loop ran while the interpreter tore its modules down)."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

pytestmark = [pytest.mark.needs_env, pytest.mark.needs_trl, pytest.mark.slow]

SCRIPT = textwrap.dedent("""
    import torch  # first, as a trainer does: it changed the order modules are torn down in
    import gymnasium
    from cocobench_agents.envs import SeatEnv, env, parallel_env

    def seat():
        return SeatEnv("demo", condition="D0_image", seat="agent_1", partner="random")

    def step(environment):
        environment.step({s: environment.action_space(s).sample() for s in environment.agents})

    kept = []
    for condition in ("C0_blind", "D1_blind", "LW_blind", "C0_image", "D1_image"):
        parallel = parallel_env("demo", condition=condition)
        parallel.reset(seed=0)
        step(parallel)  # its planner now waits on the loop for the next move
        if condition.startswith("D1"):
            parallel.close()
        kept.append(parallel)
    alone = SeatEnv("demo", condition="D1_blind", seat="agent_1", partner="random")
    alone.reset(seed=0)
    alone.step(alone.action_space.sample())
    turns = env("demo", condition="D0_blind")
    turns.reset(seed=0)
    vectors = []
    for kind in (gymnasium.vector.SyncVectorEnv, gymnasium.vector.AsyncVectorEnv):
        vector = kind([seat, seat])
        vector.reset(seed=[1, 2])
        vector.step(vector.action_space.sample())
        vectors.append(vector)
    vectors[1].close()  # the async one's workers stopped; the sync one left open
    print("played")
""")


def test_a_script_importing_torch_exits_without_errors_on_stderr(tmp_path):
    script = tmp_path / "train.py"
    script.write_text(SCRIPT)
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                          timeout=300, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "played"
    assert "Exception ignored" not in done.stderr and "Traceback" not in done.stderr, \
        done.stderr
    assert done.stderr.strip() == "", done.stderr
