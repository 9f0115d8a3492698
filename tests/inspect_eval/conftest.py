"""Shared pieces of the Inspect task's tests: real task configs, Inspect's mockllm fed a fixed
list of replies, and the environment of a subprocess `inspect eval`."""

from __future__ import annotations

import os
import shutil
import sys
import uuid
from pathlib import Path

from tests.paths import SHARED_DATA

TASKS = SHARED_DATA / "tasks"
#: Real configs: a two-agent D1 instance and a three-agent D2 one.
CONFIGS = ("A_D1__FloorPlan1__seed0.json", "C_D2__FloorPlan202__livingroom_3agent_seed1.json")
#: The replies both doors are fed: menu ids (valid or not on the menu shown), then a reply
#: that parses as nothing (it ends the episode, as in the reference), no DONE.
REPLIES = ["ACTION: 3", "ACTION: 1", "ACTION: 0", "ACTION: 2", "ACTION: 5", "ACTION: 1",
           "ACTION: 4", "ACTION: 0", "ACTION: 3", "ACTION: 2", "I am not sure."]
DONE = "ACTION: DONE"  # what a scripted client says once its replies run out


def config_paths() -> list[str]:
    return [str(TASKS / name) for name in CONFIGS]


def subprocess_env(*, checkout_first: bool = True) -> dict[str, str]:
    """This environment with, with `checkout_first`, this checkout first on the path (the
    subprocess imports the tree under test). The task finds its tokenizer offline itself
    (`inspect_eval.offline`): no tokenizer folder is set here.

    `inspect eval` runs without it: Inspect names a package's tasks (``cocobench_agents/…``)
    only when the distribution it finds first was installed (or installed editable), and a
    checkout on the path shows it the ``.egg-info`` pip leaves in the checkout's root, which
    records no install. It imports the installed package: this checkout, in CI's editable
    install."""
    env = dict(os.environ)
    if checkout_first:
        root = str(Path(__file__).resolve().parents[2])
        env["PYTHONPATH"] = os.pathsep.join(p for p in (root, os.environ.get("PYTHONPATH"))
                                            if p)
    return env


def openai_api(monkeypatch, base_url: str, key: str = "sk-fake-inspect-0001") -> str:
    """The prefix of Inspect model names (``openai-api/SERVICE``) that reach the
    OpenAI-compatible server at `base_url`: a service name of its own, since Inspect keeps
    one model per name in a process (a name used before would reach that server still)."""
    service = f"svc{uuid.uuid4().hex[:10]}"
    monkeypatch.setenv(f"{service.upper()}_BASE_URL", base_url)
    monkeypatch.setenv(f"{service.upper()}_API_KEY", key)
    return f"openai-api/{service}"


def inspect_command() -> list[str]:
    """Inspect's command as installed beside this Python (``inspect``), else the same command
    through the interpreter (a venv made with --system-site-packages has no script of it)."""
    script = shutil.which("inspect", path=str(Path(sys.executable).parent))
    return [script] if script else [sys.executable, "-m", "inspect_ai"]


def scripted_mockllm(replies: list[str]):
    """Inspect's mockllm whose `custom_outputs` replays `replies` from the start in every
    sample × epoch (then ``ACTION: DONE``, as a scripted client does): each episode gets the
    whole list, as each episode of ``--model scripted:FILE`` does."""
    from inspect_ai.log._samples import sample_active
    from inspect_ai.model import ModelOutput, get_model

    cursors: dict[tuple[object, int], int] = {}

    def output(input, tools, tool_choice, config):  # mockllm's signature
        active = sample_active()
        key = (active.sample.id, active.epoch)
        index = cursors.get(key, 0)
        cursors[key] = index + 1
        text = replies[index] if index < len(replies) else DONE
        return ModelOutput.from_content("mockllm/model", text)

    return get_model("mockllm/model", custom_outputs=output, memoize=False)
