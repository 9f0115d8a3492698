"""Prompt suites loaded from folders: specs, content hashes, variants, and every way a folder
can be wrong (each a `PromptSuiteError` naming the file and the field)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from benchmark_adapter.episode import Episode
from benchmark_adapter.tasks import load_tasks
from cocobench_agents.prompts import (
    DEFAULT_SUITE,
    TEMPLATE_FIELDS,
    PromptSuiteError,
    check_unchanged,
    load_prompt_suite,
    shipped_suite_files,
)
from cocobench_agents.tools import EpisodeTools


def export(folder: Path, name: str = DEFAULT_SUITE) -> Path:
    folder.mkdir(parents=True)
    for file_name, data in shipped_suite_files(name).items():
        (folder / file_name).write_bytes(data)
    return folder


@pytest.fixture
def suite_dir(tmp_path: Path) -> Path:
    return export(tmp_path / "my-suite")


def first_prompt(spec: str, cell: str = "J_D4") -> str:
    config = next(c for c in load_tasks("demo") if c.cell == cell)
    tools = EpisodeTools(Episode(config), load_prompt_suite(spec), obs_mode="blind")
    tools.start()
    return tools.prompt(None, [], with_images=False)[0]


# -- what a loaded suite is ------------------------------------------------------------------

def test_the_shipped_suite_has_every_template_and_a_stable_hash() -> None:
    suite = load_prompt_suite()
    assert set(suite.templates) == set(TEMPLATE_FIELDS)
    assert suite.path is None and suite.spec == DEFAULT_SUITE
    assert len(suite.content_hash) == 64
    assert suite.content_hash == load_prompt_suite(DEFAULT_SUITE).content_hash


def test_an_unedited_copy_has_the_shipped_hash_and_the_same_prompts(suite_dir: Path) -> None:
    copy, shipped = load_prompt_suite(str(suite_dir)), load_prompt_suite()
    assert copy.content_hash == shipped.content_hash
    assert copy.path == str(suite_dir.resolve()) and copy.spec == copy.path
    assert first_prompt(str(suite_dir)) == first_prompt(DEFAULT_SUITE)


def test_an_edit_changes_the_hash_and_the_prompt(suite_dir: Path) -> None:
    before = load_prompt_suite(str(suite_dir)).content_hash
    template = suite_dir / "centralized.txt"
    template.write_text(template.read_text().replace("GOAL: {goal}", "OBJECTIVE: {goal}"))
    after = load_prompt_suite(str(suite_dir))
    assert after.content_hash != before
    prompt = first_prompt(str(suite_dir))
    assert "OBJECTIVE: Bedroom" in prompt and "GOAL: Bedroom" not in prompt


def test_variants_apply_to_a_folder_and_change_the_hash(suite_dir: Path) -> None:
    plain = load_prompt_suite(str(suite_dir))
    ablated = load_prompt_suite(f"{suite_dir}+no-hint+no-history")
    assert ablated.variants == {"no-hint", "no-history"}
    assert ablated.spec == f"{suite_dir.resolve()}+no-hint+no-history"
    assert ablated.content_hash != plain.content_hash
    assert load_prompt_suite(ablated.spec) == ablated  # the spec reloads the same suite
    assert "RELAY CONSTRAINT" in first_prompt(str(suite_dir))
    text = first_prompt(f"{suite_dir}+no-hint")
    assert "RELAY CONSTRAINT" not in text and "GOAL PROGRESS" in text


def test_a_relative_path_becomes_absolute_and_a_plus_in_a_folder_name_works(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    export(tmp_path / "v1+edited")
    monkeypatch.chdir(tmp_path)
    suite = load_prompt_suite("v1+edited+no-hint")
    assert suite.path == str(tmp_path / "v1+edited") and suite.variants == {"no-hint"}
    assert load_prompt_suite("./v1+edited").variants == frozenset()


def test_a_shipped_name_wins_over_a_folder_of_that_name(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    edited = export(tmp_path / DEFAULT_SUITE)
    (edited / "msg_hint.txt").write_text("edited")
    monkeypatch.chdir(tmp_path)
    assert load_prompt_suite(DEFAULT_SUITE).path is None
    assert load_prompt_suite(f"./{DEFAULT_SUITE}").path == str(edited)


# -- how a folder can be wrong ---------------------------------------------------------------

def load_error(spec: str) -> str:
    with pytest.raises(PromptSuiteError) as caught:
        load_prompt_suite(spec)
    return str(caught.value)


def test_names_and_folders_that_do_not_exist(tmp_path: Path) -> None:
    assert "unknown prompt suite 'cocobench-v9'" in load_error("cocobench-v9")
    assert "cocobench-v1" in load_error("cocobench-v9")  # lists the shipped ones
    missing = tmp_path / "nowhere"
    assert load_error(f"{missing}+no-hint") == f"prompt suite folder {missing}: no such folder"


def test_unknown_variant(suite_dir: Path) -> None:
    message = load_error(f"{suite_dir}+no-hints")
    assert "unknown prompt variant 'no-hints'" in message and "no-hint" in message


def test_missing_suite_json(suite_dir: Path) -> None:
    (suite_dir / "suite.json").unlink()
    message = load_error(str(suite_dir))
    assert message.startswith(f"{suite_dir.resolve()}/suite.json: missing")
    assert "cocobench prompts export" in message


@pytest.mark.parametrize(("content", "expected"), [
    ("{not json", "suite.json: not valid JSON (Expecting property name"),
    ("[1, 2]", "suite.json: must be a JSON object"),
    ('{"histroy_window": 3}', "suite.json: unknown key 'histroy_window'"),
    ('{"history_window": "6"}', "suite.json: history_window must be a positive integer, not '6'"),
    ('{"message_window": 0}', "suite.json: message_window must be a positive integer, not 0"),
    ('{"version": 2}', "suite.json: version must be a string, not 2"),
])
def test_malformed_suite_json(suite_dir: Path, content: str, expected: str) -> None:
    (suite_dir / "suite.json").write_text(content)
    assert expected in load_error(str(suite_dir))


def test_missing_template(suite_dir: Path) -> None:
    (suite_dir / "hint_relay.txt").unlink()
    assert load_error(str(suite_dir)) == \
        f"{suite_dir.resolve()}/hint_relay.txt: template missing"


def test_a_file_that_is_no_template(suite_dir: Path) -> None:
    (suite_dir / "centralised.txt").write_text("typo")
    assert "centralised.txt: not a template of a prompt suite" in load_error(str(suite_dir))


@pytest.mark.parametrize(("template", "text", "expected"), [
    ("centralized.txt", "GOAL: {gaol}", "centralized.txt: unknown field {gaol} (fields of this "
                                         "template: agents, goal, hint, history_section, menu"),
    ("hint_resource.txt", "only one {knife}", "hint_resource.txt: unknown field {knife} "
                                              "(fields of this template: none)"),
    ("leader.txt", "{goal.upper}", "leader.txt: unknown field {goal.upper}"),
    ("comm_block.txt", "{}", "comm_block.txt: unknown field {}"),
    ("distributed.txt", "{n:{width}}", "distributed.txt: unknown field {width}"),
    ("distributed.txt", "a { brace", "distributed.txt: expected '}' before end of string "
                                     "(write {{ or }} for a literal brace)"),
    ("msg_hint.txt", "a } brace", "msg_hint.txt: Single '}' encountered in format string"),
    ("progress_section.txt", "{goal_progress!z}", "progress_section.txt: cannot be formatted"),
    ("state_centralized.txt", "{agent_lines:d}", "state_centralized.txt: cannot be formatted"),
])
def test_bad_fields_are_reported_at_load_time(suite_dir: Path, template: str, text: str,
                                              expected: str) -> None:
    (suite_dir / template).write_text(text)
    assert expected in load_error(str(suite_dir))


def test_fields_may_take_format_specs_and_literal_braces(suite_dir: Path) -> None:
    (suite_dir / "hint_resource.txt").write_text("{{one knife}}")
    (suite_dir / "state_centralized.txt").write_text("\nSTATE:\n{agent_lines:>4}")
    suite = load_prompt_suite(f"{suite_dir}+no-hint")
    assert suite.render("hint_resource") == "{one knife}"
    assert "{one knife}" in first_prompt(str(suite_dir), cell="K_D3")


def test_a_non_utf8_template(suite_dir: Path) -> None:
    (suite_dir / "msg_hint.txt").write_bytes(b"\xff\xfe MSG")
    assert "msg_hint.txt: not UTF-8 text" in load_error(str(suite_dir))


# -- resuming against the recorded suite -----------------------------------------------------

def test_check_unchanged_names_what_changed(suite_dir: Path) -> None:
    recorded = load_prompt_suite(str(suite_dir)).record()
    assert recorded["path"] == str(suite_dir.resolve())
    check_unchanged(load_prompt_suite(str(suite_dir)), recorded)  # same: no error
    (suite_dir / "leader.txt").write_text("{goal}")
    with pytest.raises(PromptSuiteError) as caught:
        check_unchanged(load_prompt_suite(str(suite_dir)), recorded)
    assert str(caught.value) == (
        f"--resume: prompt suite {suite_dir.resolve()} changed since the run was recorded "
        f"(changed: leader.txt); restore it, or start a new run in another --out")
    with pytest.raises(PromptSuiteError, match="differs from the recorded run's"):
        check_unchanged(load_prompt_suite(f"{suite_dir}+no-hint"), recorded)


def test_check_unchanged_accepts_records_of_older_versions() -> None:
    suite = load_prompt_suite()
    check_unchanged(suite, {"spec": DEFAULT_SUITE, "version": "1.0"})  # no hash recorded
    check_unchanged(suite, "cocobench-v1")  # type: ignore[arg-type]


def test_the_shipped_files_are_suite_json_and_one_file_per_template(suite_dir: Path) -> None:
    meta = json.loads((suite_dir / "suite.json").read_text())
    assert meta["name"] == DEFAULT_SUITE
    assert {p.name for p in suite_dir.iterdir()} == \
        {"suite.json", *(f"{k}.txt" for k in TEMPLATE_FIELDS)}
