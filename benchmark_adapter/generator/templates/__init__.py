"""The paper's ten task types, in the order of its task-definition table."""

from benchmark_adapter.generator.templates.base import Draft, TaskType, Ungroundable
from benchmark_adapter.generator.templates.d1 import D1_TYPES
from benchmark_adapter.generator.templates.d2 import D2_TYPES
from benchmark_adapter.generator.templates.d3 import D3_TYPES
from benchmark_adapter.generator.templates.d4 import D4_TYPES

TASK_TYPES: dict[str, TaskType] = {t.slug: t for t in (*D1_TYPES, *D2_TYPES, *D3_TYPES, *D4_TYPES)}

__all__ = ["TASK_TYPES", "Draft", "TaskType", "Ungroundable"]
