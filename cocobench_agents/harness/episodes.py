"""A run's episode list: models × conditions × prompt-suite arms × instances × epochs, in a
fixed order, each episode a key (its folder, its result line's key) and an `EpisodeSpec`."""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from benchmark_adapter.tasks import TaskConfig
from benchmark_adapter.vocabulary import OBSERVATION_MODES
from cocobench_agents.conditions import condition_name, split_condition
from cocobench_agents.episode_runner import DEFAULT_MODEL_KEY, EpisodeSpec
from cocobench_agents.graphs import NO_MODEL, PAPER_PLANNERS, PLANNERS, find_planner, planner_spec
from cocobench_agents.prompts import PromptSuite
from cocobench_agents.runfolder.episode_key import EpisodeKey, model_slug

PAPER_CODES = tuple(PLANNERS[name].code for name in PAPER_PLANNERS)  # as in run_eval.sh
SHORTCUTS = {  # all; and each observation mode: the paper's architectures under it
    "all": [condition_name(c, o) for c in PAPER_CODES for o in OBSERVATION_MODES],
    **{o: [condition_name(c, o) for c in PAPER_CODES] for o in OBSERVATION_MODES},
}


#: The most episodes one run plans: each is held in memory (a dry run of 200,000 took 450 MB
#: and 45 s here), and a plan is built whole before anything runs. Above a benchmark's
#: plans: cocobench-full under all six conditions, three models and the baselines is under
#: 30,000.
MAX_EPISODES = 250_000


class PlanError(ValueError):
    """A run request that cannot be planned (bad condition name, …)."""


@dataclass(frozen=True, order=True)
class Condition:
    """A planner under an observation mode, e.g. C0_image."""

    planner: str
    obs_mode: str

    @property
    def name(self) -> str:
        return condition_name(planner_spec(self.planner).code, self.obs_mode)


def parse_conditions(text: str) -> list[Condition]:
    """`all`, `image`, `blind`, or comma-separated names: `C0_image,D1_blind`, a planner
    name with a mode: `leader-worker_blind`, an installed planner's code (`CL_image`) or a
    planner of your own: `my_strategy.py:build_mine_image`."""
    names: list[str] = []
    for part in (p.strip() for p in text.split(",") if p.strip()):
        names.extend(SHORTCUTS.get(part, [part]))
    out: list[Condition] = []
    for name in dict.fromkeys(names):
        head, obs = split_condition(name)
        planner = find_planner(head) if obs else None
        if planner is None:
            codes = "|".join(spec.code for spec in PLANNERS.values())
            modes = OBSERVATION_MODES
            raise PlanError(f"unknown condition {name!r}: use all, {', '.join(modes)}, or "
                            f"<{codes}>_<{'|'.join(modes)}> (planner names, installed planners' "
                            "codes and FILE.py:NAME work too; see `cocobench planners`)")
        out.append(Condition(planner, obs))
    if not out:
        raise PlanError("no conditions given")
    _check_distinct(out)
    return out


def planner_conditions(planners: Iterable[str], obs_modes: Iterable[str]) -> list[Condition]:
    """`--planner A --planner B --obs image`: each planner is an arm, and a planner's arm is
    its condition under each observation mode (`A_image`, `B_image`). A planner is named as
    in a condition (`find_planner`: a name, a code, `FILE.py:NAME`)."""
    modes = list(dict.fromkeys(obs_modes))
    # planner_spec raises the error naming every known planner for one that is not
    names = [find_planner(p) or planner_spec(p).name for p in dict.fromkeys(planners)]
    out = [Condition(name, obs) for name in names for obs in modes]
    out = list(dict.fromkeys(out))  # two spellings of one planner are one arm
    _check_distinct(out)
    return out


def suite_arms(suites: Sequence[PromptSuite]) -> dict[str, str]:
    """The prompt-suite arms of a run (arm label → suite spec, in the order given): none for
    a single suite, whose run keeps the folders and result lines of a run without arms."""
    unique = list({s.spec: s for s in suites}.values())
    if len(unique) < 2:
        return {}
    arms: dict[str, str] = {}
    folders: dict[str, str] = {}
    for suite in unique:
        clash = arms.get(suite.label) or folders.get(model_slug(suite.label))
        if clash is not None:
            raise PlanError(f"prompt suites {clash} and {suite.spec} would share the arm "
                            f"{suite.label!r} (its run folders and report rows): rename one "
                            "of the suite folders")
        arms[suite.label] = folders[model_slug(suite.label)] = suite.spec
    return arms


def _check_distinct(conditions: list[Condition]) -> None:
    """Two planners sharing a condition code would share run folders and report rows."""
    seen: dict[str, str] = {}
    for cond in conditions:
        other = seen.setdefault(cond.name, cond.planner)
        if other != cond.planner:
            raise PlanError(f"planners {other} and {cond.planner} share the condition "
                            f"{cond.name}; give one of them another code")


@dataclass(frozen=True)
class PlannedEpisode:
    """One episode to run."""

    key: EpisodeKey
    spec: EpisodeSpec


def plan_episodes(tasks: list[TaskConfig], models: list[str], conditions: list[Condition],
                  epochs: int, *, arms: Mapping[str, str] | None = None,
                  agent_models: Mapping[str, str] | None = None,
                  **shared: Any) -> list[PlannedEpisode]:
    """Every model × condition × prompt-suite arm × instance × epoch, in that nesting
    order.

    Each episode is an `EpisodeSpec`, the one type an episode's settings travel in from the
    request to the runner: `shared` are its fields every episode of the run shares, given as
    the request holds them (``backend``, ``prompt_suite``, ``max_steps``, ``stable_ids``);
    one not given keeps `EpisodeSpec`'s default, which is the request's. `arms`: the
    prompt-suite arms (label → suite spec; `suite_arms`), instead of ``prompt_suite``;
    `agent_models`: the models of some agents of a decentralized team."""
    _check_distinct_folders(tasks, models)
    first = shared.pop("prompt_suite", None)
    suites: Mapping[str, str | None] = arms or {"": first}
    _check_size(tasks, models, conditions, len(suites), epochs)
    out, seen = [], set()
    for model in models:
        for cond in conditions:
            for arm, suite in suites.items():
                for config in tasks:
                    for epoch in range(epochs):
                        key = EpisodeKey(_model_label(model, cond), cond.name, config.task_id,
                                         epoch, arm)
                        if key not in seen:  # the oracle needs no model: plan it once
                            seen.add(key)
                            out.append(PlannedEpisode(key, _spec(
                                key, config, model, cond, suite, agent_models or {}, shared)))
    return out


def _check_size(tasks: list[TaskConfig], models: list[str], conditions: list[Condition],
                arms: int, epochs: int) -> None:
    """Refuse a plan of more than `MAX_EPISODES` before building it: each planned episode
    is held in memory (a million epochs of the demo suite grew a dry run past 1.7 GB)."""
    per_epoch = sum(len(models) if planner_spec(c.planner).uses_models else 1
                    for c in conditions) * arms * len(tasks)
    if per_epoch * epochs > MAX_EPISODES:
        raise PlanError(f"the plan holds {per_epoch * epochs:,} episodes ({per_epoch:,} per "
                        f"epoch × {epochs:,} epochs), more than one run takes "
                        f"({MAX_EPISODES:,}): split it into several runs (fewer --epochs, "
                        "models, conditions or instances in each)")


def _check_distinct_folders(tasks: list[TaskConfig], models: list[str]) -> None:
    """Two instances with one id, or two models with one folder name, would share episodes'
    folders and result keys: refuse them."""
    ids = Counter(config.task_id for config in tasks)
    twice = sorted(task_id for task_id, n in ids.items() if n > 1)
    if twice:
        raise PlanError(f"task id {twice[0]!r} is given {ids[twice[0]]} times (by several "
                        "--task sources?): each instance must have its own id")
    slugs: dict[str, str] = {}
    for model in dict.fromkeys(models):
        other = slugs.setdefault(model_slug(model), model)
        if other != model:
            raise PlanError(f"models {other!r} and {model!r} would share the episode folder "
                            f"{model_slug(model)!r}: run them into separate --out folders")


def _spec(key: EpisodeKey, config: TaskConfig, model: str, cond: Condition,
          suite: str | None, agent_models: Mapping[str, str],
          shared: dict[str, Any]) -> EpisodeSpec:
    models = {DEFAULT_MODEL_KEY: model}
    if planner_spec(cond.planner).decentralized:
        models.update(agent_models)
    arm = {} if suite is None else {"prompt_suite": suite}
    return EpisodeSpec(config=config, planner=cond.planner, models=models,
                       obs_mode=cond.obs_mode, **arm, **shared, sample_index=key.epoch,
                       episode_key=key.folder().removeprefix("episodes/"))


def _model_label(model: str, cond: Condition) -> str:
    return model if planner_spec(cond.planner).uses_models else NO_MODEL
