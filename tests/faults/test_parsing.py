"""Reading a model's reply can never execute an action the model did not choose, and whatever
the model wrote is recorded as the model's own protocol outcome, never as a harness error."""

from __future__ import annotations

import asyncio
import json

import pytest

from benchmark_adapter.tasks import load_tasks
from cocobench_agents.episode_runner import EpisodeSpec, run_episode
from cocobench_agents.harness import (
    Condition,
    ExecutionSettings,
    InProcess,
    plan_episodes,
)
from cocobench_agents.models import ModelPool, ModelSettings
from cocobench_agents.prompts import parse_message, parse_reply
from cocobench_agents.runfolder import RunFolder
from tests.models.fake_openai import FakeOpenAI, ok

MENU = [0, 1, 2, 3, 7, 12]


# -- parse_reply -----------------------------------------------------------------------------

@pytest.mark.parametrize(("text", "status", "choice", "action_id", "mode"), [
    ("REASON: go\nACTION: 12", "action", "12", 12, "action_line"),
    ("I pick 3 of course", "action", "3", 3, "bare_integer"),
    ("action: done", "done", "DONE", None, "action_line"),
    ("ACTION: 99", "invalid_action_id", "99", None, "action_line"),
    # Written forms that only look like a menu id: recorded as written, not normalised.
    ("ACTION: 007", "invalid_action_id", "007", None, "action_line"),
    ("ACTION: \u0663", "invalid_action_id", "\u0663", None, "action_line"),  # Arabic-Indic 3
    ("no digits at all", "parse_error", None, None, None),
    ("", "parse_error", None, None, None),
])
def test_reply_outcomes(text, status, choice, action_id, mode) -> None:
    parsed = parse_reply(text, MENU)
    assert (parsed.status, parsed.raw_choice, parsed.action_id, parsed.mode) == (
        status, choice, action_id, mode)


def test_a_5000_digit_id_is_the_models_invalid_id_not_a_crash() -> None:
    digits = "9" * 5_000  # int() refuses more than 4,300 digits
    for text in (f"ACTION: {digits}", f"REASON: {digits} apples"):
        parsed = parse_reply(text, MENU)
        assert parsed.status == "invalid_action_id"
        assert parsed.raw_choice == digits and parsed.action_id is None
        assert parsed.error == "action id not in current menu"


def test_a_huge_id_in_a_run_is_the_models_failure_not_an_infra_error(tmp_path) -> None:
    """Before: `int()` raised outside the decision's error handling, so the episode became an
    infrastructure error that `--retry-errors` would re-run."""
    digits = "7" * 5_000
    script = tmp_path / "replies.json"
    script.write_text(json.dumps([f"REASON: all in\nACTION: {digits}"]), encoding="utf-8")
    config = next(c for c in load_tasks("demo") if c.cell == "G_D1")
    episodes = plan_episodes([config], [f"scripted:{script}"],
                             [Condition("centralized", "blind")], 1)
    folder = RunFolder(tmp_path / "run")
    folder.create({"name": "huge-id"})
    InProcess().run(episodes, folder, ModelPool(ModelSettings()), ExecutionSettings(jobs=1))
    [result] = folder.results()
    assert "infra_error" not in result
    assert result["terminal_reason"] == "invalid_action_id"
    document = json.loads((folder.path / result["trajectory"]).read_text(encoding="utf-8"))
    [decision] = document["planner_decisions"]
    assert decision["parsed_action_id"] == digits and decision["parsed_call"] is None


def test_parsing_never_raises_on_odd_input() -> None:
    assert parse_reply(None, MENU).status == "parse_error"
    assert parse_reply(b"ACTION: 1", MENU).status == "parse_error"  # type: ignore[arg-type]
    assert parse_reply("ACTION: 1", []).status == "invalid_action_id"
    assert parse_message(None) == "" and parse_message(42) == ""  # type: ignore[arg-type]


# -- a reply cut at the size cap, through a whole episode ------------------------------------

CAP = 1_000


@pytest.mark.parametrize("dropped", [3, 12])
def test_a_truncated_reply_never_executes_the_dropped_count(dropped: int) -> None:
    """The reply has no number in it; before the fix, the truncation note's dropped count was
    read by the bare-integer fallback and that menu action was executed."""
    config = next(c for c in load_tasks("demo") if c.cell == "G_D1")
    reply = "REASON: " + "x" * (CAP - len("REASON: ") + dropped)
    with FakeOpenAI(ok(reply)) as server:
        settings = ModelSettings(api_base=server.base_url, max_reply_chars=CAP,
                                 transport="http")
        spec = EpisodeSpec(config, planner="centralized", models={"*": "openai/fake"},
                           obs_mode="blind")
        trajectory, result = asyncio.run(run_episode(spec, ModelPool(settings)))
    assert result.terminal_reason == "parse_error"
    assert not [item for item in trajectory["trajectory"] if "skill_result" in item]
    [decision] = trajectory["planner_decisions"]
    assert decision["raw_output"] == reply[:CAP]  # only what the model wrote
    assert decision["reply_truncated_chars"] == dropped
    assert decision["parsed_action_id"] is None and decision["parse_mode"] is None


def test_an_uncut_reply_records_no_truncation() -> None:
    config = next(c for c in load_tasks("demo") if c.cell == "G_D1")
    with FakeOpenAI(ok("REASON: finished\nACTION: DONE")) as server:
        settings = ModelSettings(api_base=server.base_url, max_reply_chars=CAP,
                                 transport="http")
        spec = EpisodeSpec(config, models={"*": "openai/fake"}, obs_mode="blind")
        trajectory, result = asyncio.run(run_episode(spec, ModelPool(settings)))
    assert result.terminal_reason == "done"
    assert "reply_truncated_chars" not in trajectory["planner_decisions"][0]
