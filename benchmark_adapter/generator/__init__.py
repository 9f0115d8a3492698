"""The project's own instance generator: templates × scenes → candidates → gates → suites.

* `scenes` (+ `rooms`, `layout`, `spawn`): the embedded scene catalogue of four room
  categories; `thor`: catalogue entries from AI2-THOR FloorPlan metadata.
* `templates`: the paper's ten task types, each grounded in a scene for 2–4 agents.
* `builder`: a grounded draft → a CoCoBench config; `oracles`: plans for task types the
  released cell plans do not cover; `budgets`: step budgets from the oracle's length.
* `gates`: placement, oracle and metric gates; `pipeline`: candidate streams and selection.
* `composition`: suite compositions; `suites`: suite files, writing and byte-for-byte checks.

See `docs/generator.md`.
"""

from benchmark_adapter.generator.composition import FULL_COMPOSITION, Stratum, full_strata
from benchmark_adapter.generator.gates import GATES, Verdict, judge
from benchmark_adapter.generator.pipeline import (
    GenerationError,
    StratumResult,
    generate,
    rejection_table,
    run_strata,
)
from benchmark_adapter.generator.scenes import Scene, SceneObject, catalogue, embedded_scene
from benchmark_adapter.generator.suites import (
    SUITES,
    compare_suite,
    package_data_root,
    suite_configs,
    suite_files,
    write_suite,
)
from benchmark_adapter.generator.templates import TASK_TYPES, TaskType
from benchmark_adapter.generator.thor import ThorBackendMissing, scene_from_thor_metadata

__all__ = [
    "FULL_COMPOSITION",
    "GATES",
    "SUITES",
    "TASK_TYPES",
    "GenerationError",
    "Scene",
    "SceneObject",
    "Stratum",
    "StratumResult",
    "TaskType",
    "ThorBackendMissing",
    "Verdict",
    "catalogue",
    "compare_suite",
    "embedded_scene",
    "full_strata",
    "generate",
    "judge",
    "package_data_root",
    "rejection_table",
    "run_strata",
    "scene_from_thor_metadata",
    "suite_configs",
    "suite_files",
    "write_suite",
]
