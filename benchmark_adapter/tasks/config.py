"""`TaskConfig`: the CoCoBench task-config JSON schema (reference §2).

Tolerant of unknown keys (they are kept and written back), strict about the keys the framework
reads. Aliases used by goals and constraints must be defined in `init_state.objects`.
"""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ConfigDict, Field, PrivateAttr, model_validator

from benchmark_adapter.vocabulary import Dimension


class _Open(BaseModel):
    """Base for schema parts: unknown keys are kept so configs round-trip."""

    model_config = ConfigDict(extra="allow")


class AgentSpec(_Open):
    """One agent of the team. `role` is documentation only: it is never shown to a model."""

    id: str
    role: str = ""
    allowed_skills: list[str] = Field(default_factory=list)


class ControllerInit(_Open):
    """Arguments the simulator controller is built with."""

    scene: str
    agentCount: int | None = None
    gridSize: float = 0.25
    visibilityDistance: float = 1.5


class InitState(_Open):
    """Scene set-up: the important objects and the init actions applied at reset."""

    controller_init: ControllerInit
    objects: dict[str, str]
    init_actions: list[dict[str, Any]] = Field(default_factory=list)
    design_notes: list[str] = Field(default_factory=list)


class GoalPredicate(_Open):
    """One goal check; the arguments (object, receptacle, agent, value, …) are extra keys."""

    predicate: str

    def arg(self, name: str, default: Any = None) -> Any:
        """An argument of the predicate, e.g. `arg("object")`."""
        return (self.model_extra or {}).get(name, default)


class Difficulty(_Open):
    """`difficulty.step_budget` is the budget the reference runner uses (reference §10.1)."""

    object_count: int | None = None
    step_budget: int | None = None
    partial_observability: bool | None = None
    oracle_steps: int | None = None


class TaskConfig(_Open):
    """One CoCoBench instance."""

    task_id: str
    coordination_dim: Dimension
    task_family: str
    task_name: str
    scene_id: str
    agent_count: int = Field(ge=1)
    agents: list[AgentSpec] = Field(min_length=1)
    seed: int = 0
    assignment: dict[str, str] | None = None
    init_state: InitState
    allowed_skills: list[str] = Field(default_factory=list)
    goal_predicates: list[GoalPredicate] = Field(default_factory=list)
    task_constraints: dict[str, Any] = Field(default_factory=dict)
    success_fn: str | None = None
    eval_layer: str | None = None
    difficulty: Difficulty = Field(default_factory=Difficulty)
    provenance: dict[str, Any] = Field(default_factory=dict)
    step_budget: int | None = None
    optimal_makespan: int | None = None

    # Where the config was loaded from (for error messages and listings); not serialised.
    _source: str | None = PrivateAttr(default=None)

    @model_validator(mode="after")
    def _aliases_are_defined(self) -> TaskConfig:
        objects = self.init_state.objects
        for i, goal in enumerate(self.goal_predicates):
            for key in ("object", "receptacle", "source"):
                value = goal.arg(key)
                if isinstance(value, str) and "|" not in value and value not in objects:
                    raise ValueError(
                        f"goal_predicates[{i}].{key}: alias {value!r} is not defined in "
                        "init_state.objects"
                    )
        for item in self.assignment or {}:
            if item not in objects:
                raise ValueError(
                    f"assignment.{item}: alias {item!r} is not defined in init_state.objects"
                )
        return self

    @property
    def source(self) -> str | None:
        """Path the config was loaded from, if it came from a file."""
        return self._source

    # -- derived views -------------------------------------------------------------------

    @property
    def cell(self) -> str:
        """Family × dimension, e.g. `K_D3`."""
        return f"{self.task_family}_{self.coordination_dim}"

    @property
    def agent_ids(self) -> list[str]:
        """Agent ids in config order."""
        return [a.id for a in self.agents]

    @property
    def important_ids(self) -> list[str]:
        """Object ids of the important objects, in alias order."""
        return list(self.init_state.objects.values())

    @property
    def budget(self) -> int | None:
        """The step budget the reference runner uses: `difficulty.step_budget`."""
        return self.difficulty.step_budget

    def allowed_skills_for(self, agent_id: str) -> list[str]:
        """Skills an agent may use: its own list, else the task-level list (reference §5.2)."""
        for agent in self.agents:
            if agent.id == agent_id and agent.allowed_skills:
                return agent.allowed_skills
        return self.allowed_skills

    def resolve(self, alias_or_id: str) -> str:
        """Object id of an alias; raw ids pass through."""
        return self.init_state.objects.get(alias_or_id, alias_or_id)

    @property
    def producer_consumer(self) -> dict[str, Any] | None:
        """D4 roles block, if any."""
        return self.task_constraints.get("producer_consumer")

    def producers(self) -> list[str]:
        """D4 producer agent ids (2-agent configs name one, larger teams list several)."""
        pc = self.producer_consumer or {}
        return list(pc.get("producers") or ([pc["producer"]] if pc.get("producer") else []))

    def consumers(self) -> list[str]:
        """D4 consumer agent ids."""
        pc = self.producer_consumer or {}
        return list(pc.get("consumers") or ([pc["consumer"]] if pc.get("consumer") else []))

    def to_json_dict(self) -> dict[str, Any]:
        """The config as plain JSON data, unknown keys included, nothing added."""
        return self.model_dump(mode="json", exclude_unset=True)
