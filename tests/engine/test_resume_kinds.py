"""Every setting of `RunRequest` says whether a resume may change it (`setting_kinds`), and a
resume does what the mark says: one table row per setting, each resumed against a real
recorded run."""

from __future__ import annotations

import socket
from pathlib import Path

import pytest

from cocobench_agents.engine.errors import RequestError
from cocobench_agents.engine.request import RunRequest, iter_fields, kind, nest
from cocobench_agents.engine.run import run
from cocobench_agents.setting_kinds import kind_of

TASK = "G_D1__DemoLivingRoom1__seed0"


@pytest.fixture(scope="module")
def listener():
    """Something listening on loopback, for a --ray-address that answers."""
    with socket.create_server(("127.0.0.1", 0)) as server:
        yield f"127.0.0.1:{server.getsockname()[1]}"


#: A changed value for every setting (leaf name → value, or a callable of the test's
#: context); ``None`` rows change nothing by themselves and say why.
def changes(tmp_path: Path, listener: str) -> dict[str, object]:
    return {
        # shaping: what is sent or scored
        "sources": ["demo", "cocobench-240"], "eval_set": ["G_D1"], "only_cell": "G_D1",
        "only_family": "G", "only_dim": "D1", "task_ids": [TASK], "limit": 1,
        "missing": "error", "models": ["random:1"], "agent_models": {"agent_2": "random:2"},
        "planners": ["decentralized"], "obs_modes": ["blind"], "conditions": ["C0_blind"],
        "prompt_suites": ["cocobench-v1+no-hint"], "epochs": 2, "baselines": True,
        "backend": "ai2thor", "max_steps": 3, "stable_ids": True,
        "api_base": "http://127.0.0.1:9/v1", "temperature": 0.3, "max_tokens": 50,
        "extra_params": {"top_p": 0.5}, "grammar": True, "seed": 7, "max_reply_chars": 99,
        "transport": "http",
        # run settings: how the run goes
        "api_key_env": "SOME_KEY_VARIABLE", "timeout_s": 30.0, "max_retries": 0,
        "max_concurrency": 2, "cache_dir": str(tmp_path / "cache"), "backoff_s": 0.5,
        "backoff_max_s": 5.0, "executor": "ray", "jobs": 3, "workers": 2,
        "ray_address": ("executor", "ray", listener), "thor_gpus_per_worker": 0.5,
        "ray_wait": 30.0,
        "max_cost": 10.0, "max_total_tokens": 1_000_000, "episode_timeout": 60.0,
        "episode_memory": 512.0, "stall_timeout": 30.0,
        "preflight": False,
        "out": None,  # the run folder is what is resumed: another one is another run
    }


def test_every_setting_is_marked_and_in_the_table(tmp_path):
    table = changes(tmp_path, "127.0.0.1:1")
    leaves = {path[-1] for path, _ in iter_fields()}
    assert set(table) == leaves, "every setting needs a row in this table"
    for _, info in iter_fields():
        assert kind_of(info) in ("shaping", "run")


@pytest.fixture(scope="module")
def recorded(tmp_path_factory) -> RunRequest:
    out = tmp_path_factory.mktemp("kinds") / "run"
    request = RunRequest(out=out, models=["greedy"], selection={"sources": ["demo"],
                         "limit": 2}, max_steps=2)
    assert len(run(request)) == 2
    return request


#: The rows whose changed request resumes on the Ray executor (a real local Ray).
ON_RAY = ("executor", "ray_address", "thor_gpus_per_worker")


@pytest.mark.parametrize("path", [
    pytest.param(p, id=".".join(p), marks=[pytest.mark.needs_ray] if p[-1] in ON_RAY else [])
    for p, _ in iter_fields() if p != ("out",)])
def test_a_resume_refuses_or_accepts_a_change_as_marked(path, recorded, tmp_path, listener):
    value = changes(tmp_path, listener)[path[-1]]
    flat = {path[-1]: value}
    if isinstance(value, tuple):  # a setting that needs another to be valid
        other, other_value, value = value
        flat = {other: other_value, path[-1]: value}
    if path[-1] == "thor_gpus_per_worker":
        flat["executor"] = "ray"
    changed = RunRequest.model_validate(
        _merged(recorded.model_dump(mode="python"), nest(flat)))
    assert changed != recorded
    if kind(path) == "shaping":
        with pytest.raises(RequestError, match=rf"{'.'.join(path)} \("):
            run(changed, resume=True)
    else:
        results = run(changed, resume=True)
        assert len(results) == 2 and results.errors == 0


def _merged(base: dict, update: dict) -> dict:
    out = dict(base)
    for key, value in update.items():
        out[key] = _merged(out[key], value) if isinstance(value, dict) and isinstance(
            out.get(key), dict) and key != "agent_models" and key != "extra_params" else value
    return out
