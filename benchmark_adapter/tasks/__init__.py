"""CoCoBench task configs: the schema, loading from files/folders/indexes/suites, selection."""

from .config import AgentSpec, GoalPredicate, TaskConfig
from .errors import TaskConfigError
from .loading import MissingTasksWarning, available_suites, load_task, load_tasks
from .selection import eval_sets_of, select_tasks

__all__ = [
    "AgentSpec",
    "GoalPredicate",
    "MissingTasksWarning",
    "TaskConfig",
    "TaskConfigError",
    "available_suites",
    "eval_sets_of",
    "load_task",
    "load_tasks",
    "select_tasks",
]
