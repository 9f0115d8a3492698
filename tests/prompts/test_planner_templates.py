"""A strategy's own prompt templates belong to the prompt suite (`PlannerSpec.templates`):
`prompts export --planner` writes them, `prompts show --template` renders them, a suite
folder's NAME.txt replaces one, the suite's hash covers them, variants apply to them, and a
resume refuses an edited one. Every mistake is one line naming the file or template."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from benchmark_adapter.episode import Episode
from benchmark_adapter.tasks import load_tasks
from cocobench_agents.cli import main
from cocobench_agents.prompts import (
    DEFAULT_SUITE,
    PromptSuiteError,
    load_prompt_suite,
    merged_templates,
)
from cocobench_agents.tools import EpisodeTools

ROOT = Path(__file__).resolve().parents[2]
SEALED_BID = f"{ROOT / 'examples' / 'strategies' / 'sealed_bid.py'}:SEALED_BID"
G_D1 = "G_D1__DemoLivingRoom1__seed0"
CONFIG = next(c for c in load_tasks("demo") if c.task_id == "G_D1__DemoLivingRoom1__seed0")
OWN = {"pricing": "You are {me}. {goal}\n{progress_section}Price of {object}?\n{menu}\n"}


@pytest.fixture(autouse=True)
def fresh_planners():
    from cocobench_agents.graphs.plugins import forget_user_planners

    forget_user_planners()
    yield
    forget_user_planners()


def cocobench(capsys, *argv) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    return code, out, err


def exported(capsys, folder: Path, *planners: str) -> Path:
    options = [a for ref in planners for a in ("--planner", ref)]
    code, _, err = cocobench(capsys, "prompts", "export", DEFAULT_SUITE, folder, *options)
    assert code == 0, err
    return folder


# -- the suite -------------------------------------------------------------------------------

def test_a_planners_templates_join_the_suite_and_its_hash():
    plain = load_prompt_suite(DEFAULT_SUITE)
    suite = load_prompt_suite(DEFAULT_SUITE, OWN)
    assert suite.templates["pricing"] == OWN["pricing"] and suite.own == {"pricing"}
    assert "pricing.txt" in suite.record()["files"]
    assert suite.content_hash != plain.content_hash
    assert suite.content_hash == load_prompt_suite(DEFAULT_SUITE, dict(OWN)).content_hash
    edited = load_prompt_suite(DEFAULT_SUITE, {"pricing": OWN["pricing"] + "!"})
    assert edited.content_hash != suite.content_hash


def test_a_folders_file_replaces_the_default_and_is_read_only_with_its_planner(tmp_path):
    folder = tmp_path / "suite"
    folder.mkdir()
    for name, data in load_prompt_suite().templates.items():
        (folder / f"{name}.txt").write_text(data)
    (folder / "suite.json").write_text("{}")
    (folder / "pricing.txt").write_text("{me}: the price of {object}?\n{menu}")
    with pytest.raises(PromptSuiteError, match=r"pricing\.txt: not a template of a prompt "
                                               r"suite .*read only with that planner"):
        load_prompt_suite(str(folder))
    suite = load_prompt_suite(str(folder), OWN)
    assert suite.templates["pricing"] == "{me}: the price of {object}?\n{menu}"
    assert suite.content_hash != load_prompt_suite(DEFAULT_SUITE, OWN).content_hash
    with pytest.raises(PromptSuiteError, match=r"stray\.txt: not a template .*planners' own: "
                                               r"pricing"):
        (folder / "stray.txt").write_text("x")
        load_prompt_suite(str(folder), OWN)


def test_a_replacement_may_use_the_view_fields_and_the_defaults_own(tmp_path):
    folder = tmp_path / "suite"
    folder.mkdir()
    for name, data in load_prompt_suite().templates.items():
        (folder / f"{name}.txt").write_text(data)
    (folder / "suite.json").write_text("{}")
    (folder / "pricing.txt").write_text("{hint}{history_section}{inv} {object}")
    load_prompt_suite(str(folder), OWN)
    (folder / "pricing.txt").write_text("{me} {objekt}")
    with pytest.raises(PromptSuiteError, match=r"pricing\.txt: unknown field \{objekt\} "
                                               r"\(fields of this template: .*object"):
        load_prompt_suite(str(folder), OWN)


@pytest.mark.parametrize(("templates", "message"), [
    ({"centralized": "x"}, "the name of a suite template"),
    ({"Pricing": "x"}, "lower-case letters, digits and _"),
    ({"../pricing": "x"}, "lower-case letters"),
    ({"suite": "x"}, "the name of a suite template"),
    ({"pricing": 3}, "its default must be a string, not int"),
    ({"pricing": "{object"}, "expected '}' before end of string"),
    ({"pricing": "{0} and {1}"}, r"field \{0\}: a field is a name"),
    ({"pricing": "{me.upper}"}, r"field \{me.upper\}: a field is a name"),
    ({"pricing": "{n:q}"}, "cannot be formatted"),
])
def test_a_bad_own_template_is_one_line_naming_it(templates, message):
    with pytest.raises(PromptSuiteError, match=message) as caught:
        load_prompt_suite(DEFAULT_SUITE, templates)
    assert "\n" not in str(caught.value) and "template" in str(caught.value)


def test_two_planners_may_share_a_template_only_with_one_text():
    assert merged_templates({"a": OWN, "b": OWN}) == OWN
    with pytest.raises(PromptSuiteError, match="planners a and b both declare the template "
                                               "'pricing'"):
        merged_templates({"a": OWN, "b": {"pricing": "other"}})


def test_variants_apply_to_a_planners_template_and_a_missing_field_is_named():
    def render(spec: str, fields: dict) -> str:
        tools = EpisodeTools(Episode(CONFIG), load_prompt_suite(spec, OWN), obs_mode="blind")
        tools.start()
        return tools.ask_prompt("agent_1", "pricing", fields, (), with_images=False)[0]

    full = render(DEFAULT_SUITE, {"object": "Book"})
    assert "GOAL PROGRESS" in full and "Price of Book?" in full
    assert "GOAL PROGRESS" not in render(f"{DEFAULT_SUITE}+no-progress", {"object": "Book"})
    with pytest.raises(ValueError, match=r"template 'pricing' uses the field \{object\}, which "
                                         r"was not given \(given: none"):
        render(DEFAULT_SUITE, {})


# -- the CLI ---------------------------------------------------------------------------------

def test_export_writes_a_planners_templates_and_the_copy_loads_with_it(capsys, tmp_path):
    folder = exported(capsys, tmp_path / "suite", SEALED_BID)
    from cocobench_agents.graphs import planner_spec

    spec = planner_spec(SEALED_BID)
    assert (folder / "pricing.txt").read_text() == spec.templates["pricing"]
    copy = load_prompt_suite(str(folder), spec.templates)
    assert copy.content_hash == load_prompt_suite(DEFAULT_SUITE, spec.templates).content_hash


def test_show_renders_a_planners_template_with_its_fields_as_placeholders(capsys):
    code, out, err = cocobench(capsys, "prompts", "show", "--source", "demo", "--task", G_D1,
                               "--obs", "blind", "--planner", SEALED_BID,
                               "--template", "pricing")
    assert code == 0, err
    assert out.startswith("You are agent_1, one of 2 robots")
    assert "the {object} this round; you chose: {wanted}" in out and "{menu}" in out
    assert err.startswith("# step 0 pricing template")
    code, _, err = cocobench(capsys, "prompts", "show", "--source", "demo", "--task", G_D1,
                             "--planner", SEALED_BID, "--template", "pricng")
    assert code == 2 and "has no template 'pricng' (its own: pricing)" in err


def test_a_run_hashes_the_template_and_a_resume_refuses_an_edited_one(capsys, tmp_path):
    folder = exported(capsys, tmp_path / "suite", SEALED_BID)
    out = tmp_path / "run"
    argv = ["run", "--planner", SEALED_BID, "--model", "greedy", "--suite", "demo",
            "--task-id", G_D1, "--obs", "blind", "--max-steps", "3", "--prompt-suite", folder,
            "--out", out]
    code, _, err = cocobench(capsys, *argv)
    assert code == 0, err
    recorded = json.loads((out / "run.json").read_text())["prompt_suite"]
    assert "pricing.txt" in recorded["files"]
    (folder / "pricing.txt").write_text("{me}: your price for {object}?\n{menu}")
    code, _, err = cocobench(capsys, *argv, "--resume")
    assert code == 2 and "changed: pricing.txt" in err


# -- a stranger's template file ----------------------------------------------------------------

@settings(max_examples=60, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(text=st.text(alphabet=st.sampled_from("{}:!<>0123456789 abcdefmnoptxy_\n.[]"),
                    max_size=40))
def test_any_text_in_a_template_file_loads_or_is_one_line_naming_it(tmp_path_factory, text):
    """A suite folder's `pricing.txt` is data from whoever wrote the folder: it loads, or it
    is refused with one line naming the file; once loaded it renders with the strategy's
    fields, or names the field it lacks."""
    folder = tmp_path_factory.mktemp("suite")
    for name, data in load_prompt_suite().templates.items():
        (folder / f"{name}.txt").write_text(data)
    (folder / "suite.json").write_text("{}")
    (folder / "pricing.txt").write_text(text)
    try:
        suite = load_prompt_suite(str(folder), OWN)
    except PromptSuiteError as exc:
        assert str(exc).startswith(f"{folder}/pricing.txt: ") and "\n" not in str(exc)
        return
    assert suite.templates["pricing"] == text
    tools = EpisodeTools(Episode(CONFIG), suite, obs_mode="blind")
    tools.start()
    try:
        prompt, _ = tools.ask_prompt("agent_1", "pricing", {"object": "Book"}, (),
                                     with_images=False)
    except ValueError as exc:  # a view field of the team's (state) in an agent's ask
        assert "which was not given" in str(exc)
    else:
        assert isinstance(prompt, str)


@settings(max_examples=80, deadline=None)
@given(text=st.text(alphabet=st.sampled_from("{}:!<>0123456789 abmnoxy_.[]"), max_size=30))
def test_any_default_text_loads_or_is_one_line_naming_its_template(text):
    try:
        suite = load_prompt_suite(DEFAULT_SUITE, {"pricing": text})
    except PromptSuiteError as exc:
        assert str(exc).startswith("planner template 'pricing': ") and "\n" not in str(exc)
    else:
        assert suite.templates["pricing"] == text


def test_a_suites_label_and_spec_need_not_read_its_files(capsys, tmp_path):
    """An arm's name (Inspect's sample ids) and a run's canonical spec come from the spec
    alone: a folder holding a planner's template is named without that planner."""
    from cocobench_agents.prompts import suite_label, suite_spec

    folder = exported(capsys, tmp_path / "auction", SEALED_BID)
    assert suite_label(f"{folder}+no-hint") == "auction+no-hint"
    assert suite_spec(f"{folder}+no-hint+no-progress") == f"{folder}+no-hint+no-progress"
    from cocobench_agents.graphs import planner_spec

    loaded = load_prompt_suite(f"{folder}+no-hint", planner_spec(SEALED_BID).templates)
    assert (loaded.label, loaded.spec) == ("auction+no-hint", f"{folder}+no-hint")
