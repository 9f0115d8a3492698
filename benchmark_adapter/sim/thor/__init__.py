"""The real AI2-THOR 5.0 backend (`pip install 'cocobench-agents[thor]'`).

Importing this package does not import ai2thor: that happens when a controller starts.
No ai2thor object leaves it; see docs/ai2thor-backend.md.
"""

from benchmark_adapter.sim.thor.controller import ThorController
from benchmark_adapter.sim.thor.environment import preflight, probe
from benchmark_adapter.sim.thor.errors import ThorCrashed, ThorUnavailable
from benchmark_adapter.sim.thor.options import ThorOptions
from benchmark_adapter.sim.thor.pool import POOL

__all__ = [
    "POOL",
    "ThorController",
    "ThorCrashed",
    "ThorOptions",
    "ThorUnavailable",
    "preflight",
    "probe",
]
