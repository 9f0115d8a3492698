"""`RunRequest`: every setting of a run, typed, in one frozen object.

The command line, config files, ``COCOBENCH_RUN_*`` variables, `evaluate()`, the LangGraph
`episode` graph and the Ray driver all end in one of these; `run(request)` is the only way
into a run. Each field says where it is defined whether changing it changes what is sent or
scored (`shaping`: a resumed run refuses a change) or only how the run goes (`run_setting`:
a resume accepts it); see `setting_kinds`.

Importing this module is cheap: no LangGraph, LiteLLM, click or rich.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, field_validator
from pydantic.fields import FieldInfo

from benchmark_adapter.vocabulary import (
    AI2THOR,
    DEFAULT_BACKEND,
    DEFAULT_TASKS,
    IMAGE,
    Backend,
    ObservationMode,
)
from cocobench_agents.graphs.registry import DEFAULT_PLANNER, PLANNERS
from cocobench_agents.harness.execution_settings import ExecutionSettings
from cocobench_agents.harness.runaway import RunawayLimits
from cocobench_agents.models.human import HUMAN
from cocobench_agents.models.settings import ModelSettings
from cocobench_agents.prompts.suite import DEFAULT_SUITE
from cocobench_agents.setting_kinds import Kind, kind_of, run_setting, shaping

MODEL_EPISODE_TIMEOUT_S = 7200.0  # `limits.episode_timeout` of an episode without a person
THOR_STALL_S = 1800.0  # `limits.stall_timeout` on AI2-THOR: Unity's start blocks for minutes


class Settings(BaseModel):
    """A frozen group of settings that refuses unknown keys (a typo in a config file is an
    error, not a silently ignored setting) and numbers that are not finite (``nan`` and
    ``inf`` fail every comparison a limit makes)."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)


def _one_or_more(value: Any) -> Any:
    """A list field given one value (``models="greedy"``, one ``--model``) is a list of it."""
    return [value] if isinstance(value, (str, Path)) else value


class TaskSelection(Settings):
    """Which instances run: sources, then the reference's eval-set selection."""

    sources: list[str] = shaping(
        default_factory=lambda: [DEFAULT_TASKS], flag="--task", min_length=1,
        description="Suite names (cocobench-240, cocobench-full, demo), task-config files or "
                    "folders, the reference's index.json, or subset files such as rep240.json.")
    eval_set: list[str] = shaping(
        default_factory=list, flag="--eval-set",
        description="Cells, dims, families, curated sets or task ids to keep.")
    only_cell: str | None = shaping(None, flag="--only-cell",
                                    description="Keep only this cell (e.g. A_D1).")
    only_family: str | None = shaping(None, flag="--only-family",
                                      description="Keep only this task family.")
    only_dim: str | None = shaping(
        None, flag="--only-dim", description="Keep only this coordination dimension (D1..D4).")
    task_ids: list[str] = shaping(default_factory=list, flag="--task-id",
                                  description="Keep only these task ids.")
    limit: int = shaping(0, flag="--limit", ge=0, description="At most K instances (0: all).")
    missing: Literal["skip", "error"] = shaping(
        "skip", flag="--missing",
        description="Tasks an index or subset file lists but whose configs are absent: skip "
                    "them with a warning (as the reference's eval-set selection) or stop.")

    @field_validator("sources", "eval_set", "task_ids", mode="before")
    @classmethod
    def _lists(cls, value: Any) -> Any:
        return _one_or_more(value)


class Limits(Settings):
    """When the run stops starting episodes, and how long one may take."""

    max_cost: float | None = run_setting(
        None, flag="--max-cost", ge=0,
        description="USD: stop starting episodes once the run's model calls cost this much "
                    "(episodes in flight finish; a resume with a higher limit completes).")
    max_total_tokens: int | None = run_setting(
        None, flag="--max-total-tokens", ge=0,
        description="Stop starting episodes once the run's model calls used this many tokens "
                    "(prompt + completion).")
    episode_timeout: float | None = run_setting(
        None, flag="--episode-timeout", ge=0,
        description="Wall-clock seconds an episode may run before it ends as an "
                    "infrastructure error (0: no limit; default: 7200 for episodes of "
                    "models, no limit for episodes with a human seat).")

    episode_memory: float = run_setting(
        RunawayLimits.episode_memory_mb, flag="--episode-memory", gt=0,
        description="MB an episode may add to its worker's memory: a worker past this times "
                    "its episodes in flight (or with the machine about to run out) is stopped, "
                    "its episodes run again alone, and one that does it again ends as a "
                    "'memory' infrastructure error.")
    stall_timeout: float | None = run_setting(
        None, flag="--stall-timeout", gt=0,
        description="Seconds a worker's event loop may stay busy without yielding before the "
                    "worker is stopped; its episodes run again alone, and one that does it "
                    "again ends as a 'stalled' infrastructure error (default: 120; 1800 with "
                    "the ai2thor backend, whose steps block and whose first start may "
                    "download Unity).")

    def runaway(self, backend: str) -> RunawayLimits:
        """When the executor stops a runaway episode's worker, on `backend`."""
        default = THOR_STALL_S if backend == AI2THOR else RunawayLimits.stall_s
        return RunawayLimits(self.episode_memory, self.stall_timeout or default)

    def episode_timeout_s(self, human: bool) -> float | None:
        """The wall-clock limit of an episode (None: none); `human`: it has a human seat,
        whose think time has no default limit."""
        if self.episode_timeout is None:
            return None if human else MODEL_EPISODE_TIMEOUT_S
        return self.episode_timeout or None


class RunRequest(Settings):
    """Every setting of a run: what runs (instances, models, planners or conditions, prompt
    suites, epochs), how models are called, where episodes execute, and the limits.

    Every model × condition × prompt-suite arm × instance × epoch is one episode.
    """

    model_config = ConfigDict(frozen=True, extra="forbid", protected_namespaces=(),
                              allow_inf_nan=False)

    out: Path = run_setting(flag="--out", description="The run folder.")
    selection: TaskSelection = shaping(default_factory=TaskSelection,
                                       description="Which instances run.")
    models: list[str] = shaping(
        default_factory=list, flag="--model",
        description="LiteLLM model strings or built-ins (greedy, random[:SEED], "
                    "scripted:PATH, replay:PATH), or human: a person plays every seat.")
    agent_models: dict[str, str] = shaping(
        default_factory=dict, flag="--agent-model",
        description="A different model for one agent of a decentralized team "
                    "(AGENT=MODEL, or a mapping in a config file; agent_1=human: a person "
                    "plays that agent).")
    planners: list[str] = shaping(
        default_factory=lambda: [DEFAULT_PLANNER], flag="--planner", min_length=1,
        description=f"{', '.join(PLANNERS)}, an installed planner (`cocobench planners`) "
                    "or your own "
                    "(FILE.py:NAME, module:NAME). Several: each is an arm (its condition, "
                    "under each observation mode).")
    obs_modes: list[ObservationMode] = shaping(
        default_factory=lambda: [IMAGE], flag="--obs", min_length=1,
        description="Observation modes the planners run under.")
    conditions: list[str] | None = shaping(
        None, flag="--conditions",
        description="Instead of planners × observation modes: all, image, blind, or "
                    "condition names such as C0_image,D1_blind.")
    prompt_suites: list[str] = shaping(
        default_factory=lambda: [DEFAULT_SUITE], flag="--prompt-suite", min_length=1,
        description="Prompt suites: shipped names or suite folders, with ablations joined by "
                    "'+' (cocobench-v1+no-hint). Several: each is an arm, crossed with models "
                    "and conditions.")
    epochs: int = shaping(1, flag="--epochs", ge=1,
                          description="Runs of every episode (seeds differ per epoch).")
    baselines: bool = shaping(
        False, flag="--baselines",
        description="Also run the reference rows on the same instances: the oracle (the "
                    "upper bound) and the greedy and random built-in models.")
    backend: Backend = shaping(
        DEFAULT_BACKEND, flag="--backend",
        description="Simulator: the embedded one, or real AI2-THOR (pip install "
                    "'cocobench-agents[thor]').")
    max_steps: int | None = shaping(None, flag="--max-steps", ge=1,
                                    description="Override every instance's step budget.")
    stable_ids: bool = shaping(
        False, flag="--stable-ids",
        description="Menu ids that never shift within an episode (deviation from the "
                    "reference).")
    model_settings: ModelSettings = shaping(
        default_factory=ModelSettings, description="How remote models are called.")
    execution: ExecutionSettings = run_setting(
        default_factory=ExecutionSettings, description="Where and how many episodes run.")
    limits: Limits = run_setting(default_factory=Limits,
                                 description="Spend limits and the episode timeout.")
    preflight: bool = run_setting(
        True, flag="--preflight",
        description="One call per remote model and input kind before any episode starts "
                    "(it stops the run when the provider refuses).")

    @field_validator("models", "planners", "obs_modes", "prompt_suites", mode="before")
    @classmethod
    def _lists(cls, value: Any) -> Any:
        return _one_or_more(value)

    @field_validator("conditions", mode="before")
    @classmethod
    def _condition_list(cls, value: Any) -> Any:
        """``"C0_image,D1_blind"`` (a flag, a variable) is two conditions."""
        if isinstance(value, str):
            return [part.strip() for part in value.split(",") if part.strip()]
        return value

    @field_validator("agent_models", mode="before")
    @classmethod
    def _agent_pairs(cls, value: Any) -> Any:
        """``["agent_2=gpt-4o"]`` (flags, a variable) is ``{"agent_2": "gpt-4o"}``."""
        if isinstance(value, str):
            value = value.split()
        if not isinstance(value, (list, tuple)):
            return value
        pairs = {}
        for pair in value:
            agent, sep, model = str(pair).partition("=")
            if not sep or not agent.strip() or not model.strip():
                raise ValueError(f"{pair!r}: expected AGENT=MODEL, e.g. agent_2=gpt-4o")
            pairs[agent.strip()] = model.strip()
        return pairs

    @property
    def has_human_seats(self) -> bool:
        """Whether a person plays some seat (``human`` among the models or agent models):
        such a run needs a `SeatDesk` and runs its episodes one after another here."""
        return HUMAN in self.models or HUMAN in self.agent_models.values()


def iter_fields(model: type[BaseModel] = RunRequest, prefix: tuple[str, ...] = ()
                ) -> Iterator[tuple[tuple[str, ...], FieldInfo]]:
    """Every leaf setting of `model` as (path, field), nested groups walked in order."""
    for name, info in model.model_fields.items():
        path = (*prefix, name)
        annotation = info.annotation
        if isinstance(annotation, type) and issubclass(annotation, BaseModel):
            yield from iter_fields(annotation, path)
        else:
            yield path, info


def kind(path: tuple[str, ...] | str) -> Kind:
    """Whether the setting at `path` (``("model_settings", "temperature")`` or
    ``"model_settings.temperature"``) is shaping or a run setting."""
    parts = tuple(path.split(".")) if isinstance(path, str) else path
    fields = dict(iter_fields())
    if parts not in fields:
        raise KeyError(".".join(parts))
    return kind_of(fields[parts])


def leaf_paths() -> dict[str, tuple[str, ...]]:
    """Each leaf setting's name → its path (leaf names are unique across the request, so a
    flag or a ``COCOBENCH_RUN_*`` variable names one setting)."""
    return {path[-1]: path for path, _ in iter_fields()}


def value_at(request: BaseModel, path: tuple[str, ...]) -> Any:
    """The value of the setting at `path`."""
    value: Any = request
    for part in path:
        value = getattr(value, part)
    return value


def nest(flat: dict[str, Any]) -> dict[str, Any]:
    """Settings by leaf name (``{"jobs": 4}``) nested as the request holds them
    (``{"execution": {"jobs": 4}}``)."""
    paths = leaf_paths()
    nested: dict[str, Any] = {}
    for name, value in flat.items():
        *groups, leaf = paths[name]
        node = nested
        for group in groups:
            node = node.setdefault(group, {})
        node[leaf] = value
    return nested
