"""What a run consists of: models × conditions × instances × epochs, in a fixed order."""

from __future__ import annotations

from dataclasses import dataclass, field

from benchmark_adapter.tasks import TaskConfig
from cocobench_agents.episode_runner import DEFAULT_MODEL_KEY, EpisodeSpec
from cocobench_agents.graphs import PLANNERS, find_planner, planner_spec
from cocobench_agents.harness.store import EpisodeKey
from cocobench_agents.prompts import DEFAULT_SUITE

OBS_MODES = ("image", "blind")
PAPER_CODES = ("C0", "D0", "D1")  # the paper's architectures, as in run_eval.sh
SHORTCUTS = {
    "all": [f"{c}_{o}" for c in PAPER_CODES for o in OBS_MODES],
    "image": [f"{c}_image" for c in PAPER_CODES],
    "blind": [f"{c}_blind" for c in PAPER_CODES],
}


class PlanError(ValueError):
    """A run request that cannot be planned (bad condition name, …)."""


@dataclass(frozen=True, order=True)
class Condition:
    """A planner under an observation mode, e.g. C0_image."""

    planner: str
    obs_mode: str

    @property
    def name(self) -> str:
        return f"{planner_spec(self.planner).code}_{self.obs_mode}"


def parse_conditions(text: str) -> list[Condition]:
    """`all`, `image`, `blind`, or comma-separated names: `C0_image,D1_blind`, a planner
    name with a mode: `leader-worker_blind`, an installed planner's code (`CL_image`) or a
    planner of your own: `my_strategy.py:build_mine_image`."""
    names: list[str] = []
    for part in (p.strip() for p in text.split(",") if p.strip()):
        names.extend(SHORTCUTS.get(part, [part]))
    out: list[Condition] = []
    for name in dict.fromkeys(names):
        head, _, obs = name.rpartition("_")
        planner = find_planner(head) if head and obs in OBS_MODES else None
        if planner is None:
            codes = "|".join(spec.code for spec in PLANNERS.values())
            raise PlanError(f"unknown condition {name!r}: use all, image, blind, or "
                            f"<{codes}>_<image|blind> (planner names, installed planners' "
                            "codes and FILE.py:NAME work too; see `cocobench planners`)")
        out.append(Condition(planner, obs))
    if not out:
        raise PlanError("no conditions given")
    _check_distinct(out)
    return out


def _check_distinct(conditions: list[Condition]) -> None:
    """Two planners sharing a condition code would share run folders and report rows."""
    seen: dict[str, str] = {}
    for cond in conditions:
        other = seen.setdefault(cond.name, cond.planner)
        if other != cond.planner:
            raise PlanError(f"planners {other} and {cond.planner} share the condition "
                            f"{cond.name}; give one of them another code")


@dataclass(frozen=True)
class RunOptions:
    """Episode options shared by the whole run."""

    backend: str = "embedded"
    prompt_suite: str = DEFAULT_SUITE
    max_steps: int | None = None
    stable_ids: bool = False
    agent_models: dict[str, str] = field(default_factory=dict)  # heterogeneous teams


@dataclass(frozen=True)
class PlannedEpisode:
    """One episode to run."""

    key: EpisodeKey
    spec: EpisodeSpec


def plan_episodes(tasks: list[TaskConfig], models: list[str], conditions: list[Condition],
                  epochs: int, options: RunOptions) -> list[PlannedEpisode]:
    """Every model × condition × instance × epoch, in that nesting order."""
    out, seen = [], set()
    for model in models:
        for cond in conditions:
            for config in tasks:
                for epoch in range(epochs):
                    key = EpisodeKey(_model_label(model, cond), cond.name, config.task_id, epoch)
                    if key not in seen:  # the oracle needs no model: plan it once
                        seen.add(key)
                        out.append(PlannedEpisode(key, _spec(key, config, model, cond,
                                                             options)))
    return out


def _spec(key: EpisodeKey, config: TaskConfig, model: str, cond: Condition,
          options: RunOptions) -> EpisodeSpec:
    models = {DEFAULT_MODEL_KEY: model}
    if planner_spec(cond.planner).decentralized:
        models.update(options.agent_models)
    return EpisodeSpec(config=config, planner=cond.planner, models=models,
                       obs_mode=cond.obs_mode, prompt_suite=options.prompt_suite,
                       backend=options.backend, max_steps=options.max_steps,
                       stable_ids=options.stable_ids, sample_index=key.epoch,
                       episode_key=key.folder().removeprefix("episodes/"))


def _model_label(model: str, cond: Condition) -> str:
    return model if planner_spec(cond.planner).uses_models else "oracle"
