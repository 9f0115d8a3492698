"""The Python API: `evaluate` runs exactly what `cocobench run` runs, into the same run folder,
and returns the episode results; `score` and `report` do what their commands do."""

from __future__ import annotations

import asyncio
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from benchmark_adapter.vocabulary import IMAGE
from cocobench_agents.conditions import SEPARATOR, condition_name
from cocobench_agents.engine.config import layered_request
from cocobench_agents.engine.errors import is_user_error
from cocobench_agents.engine.request import RunRequest, leaf_paths, nest
from cocobench_agents.engine.results import EvalResults

#: `evaluate` keywords named as the command line's options, where the request's field has
#: another name.
_ALIASES = {"timeout": "timeout_s", "extra": "extra_params", "extra_json": "extra_params",
            "task_id": "task_ids", "cache": "cache_dir", "obs_mode": "obs_modes",
            "planner": "planners", "prompt_suite": "prompt_suites", "model": "models"}
#: The conditions of a call that names none: the request's default planner (centralized, C0)
#: under its default observation mode.
_DEFAULT_CONDITIONS = condition_name("C0", IMAGE)
#: Keywords of the call, not of the request.
_CALL = ("resume", "retry_errors")

__all__ = ["EvalResults", "EvaluationError", "evaluate", "evaluate_async", "report",
           "request_of", "score"]


class EvaluationError(ValueError):
    """What `cocobench run` would report as a mistake (exit 2): a bad option, an unusable
    task config, model or run folder (the original error is its ``__cause__``)."""


def evaluate(source: str | Path | Sequence[str | Path] | None = None, *,
             models: str | Sequence[str], out: str | Path,
             conditions: str | Sequence[str] = _DEFAULT_CONDITIONS,
             planners: Sequence[str] | None = None,
             prompt_suites: Sequence[str] | None = None,
             **run_options: Any) -> EvalResults:
    """Run `models` on the instances of `source` (a suite name, config file or folder, index or
    subset file; several for several; default cocobench-240) under `conditions`, into the run
    folder `out`, as ``cocobench run`` does; return the results of every planned episode.

    `planners` (names, ``FILE.py:NAME`` or ``module:NAME``) run each planner under the
    observation modes of `conditions`; `prompt_suites` (names or folders, ``+variant``s) are
    arms crossed with models and conditions. Any other setting of a run is a keyword, named
    as its field or its option: ``max_steps=10``, ``jobs=4``, ``api_base="http://…"``;
    ``resume=True`` and ``retry_errors=True`` complete a recorded run.
    """
    from cocobench_agents.engine.run import run
    from cocobench_agents.graphs.plugins import forget_user_planners

    forget_user_planners()  # a strategy file edited since the last call is read afresh
    call = {name: bool(run_options.pop(name, False)) for name in _CALL}
    try:
        request = request_of(source, models=models, out=out, conditions=conditions,
                             planners=planners, prompt_suites=prompt_suites, **run_options)
        results = run(request, **call)
    except Exception as exc:
        if not is_user_error(exc):
            raise
        raise EvaluationError(str(exc)) from exc  # the error the command reports, exit 2
    if results.errors:
        warnings.warn(f"{results.errors} episodes of {out} ended on infrastructure errors; "
                      "re-run them with evaluate(..., resume=True, retry_errors=True)",
                      stacklevel=2)
    if results.planner_errors:  # the strategy's own: a re-run fails the same way
        warnings.warn(f"{results.planner_errors} episodes of {out} ended on a planner error "
                      "(the strategy's own code: each result's planner_error names the node, "
                      "file and line); fix the strategy, then evaluate into a new out",
                      stacklevel=2)
    return results


async def evaluate_async(source: str | Path | Sequence[str | Path] | None = None,
                         **kwargs: Any) -> EvalResults:
    """`evaluate` for code already inside an event loop (notebooks): it runs on a thread,
    which runs its own event loop."""
    return await asyncio.to_thread(evaluate, source, **kwargs)


def request_of(source: Any = None, *, models: Any, out: Any, conditions: Any = _DEFAULT_CONDITIONS,
               planners: Any = None, prompt_suites: Any = None, **options: Any) -> RunRequest:
    """The `RunRequest` that `evaluate` stands for (`TypeError` for an unknown keyword)."""
    names = [c for part in _listed(conditions) for c in part.split(",") if c]
    given: dict[str, Any] = {"out": out, "models": _listed(models)}
    if source is not None:
        given["sources"] = _listed(source)
    if planners:  # planner arms: each planner under the observation modes of `conditions`
        given["planners"] = _listed(planners)
        given["obs_modes"] = list(dict.fromkeys(c.rpartition(SEPARATOR)[2] for c in names))
    else:
        given["conditions"] = names
    if prompt_suites:
        given["prompt_suites"] = _listed(prompt_suites)
    for name, value in options.items():
        if name == "no_preflight":
            name, value = "preflight", not value
        name = _ALIASES.get(name, name)
        if name not in leaf_paths() or name in given:
            raise TypeError(f"evaluate() has no option {name!r} (see `cocobench run --help` "
                            "and cocobench_agents.RunRequest)")
        given[name] = value
    return layered_request(nest(given))  # a bad value: `ConfigError`, one line per problem


def score(trajectory: str | Path) -> Any:
    """The scored `EpisodeResult` of one ``trajectory.json`` (ours or the reference's)."""
    from benchmark_adapter.metrics import score_trajectory
    from benchmark_adapter.trajectory import load_trajectory

    return score_trajectory(load_trajectory(trajectory))


def report(runs: str | Path | Sequence[str | Path], out: str | Path, **options: Any) -> Any:
    """Write the paper's tables and figures for `runs` into `out` (as ``cocobench report``);
    returns what was written (files and warnings)."""
    from cocobench_agents.reports import build_report

    return build_report([str(r) for r in _listed(runs)], Path(out), **options)


def _listed(value: Any) -> list[str]:
    if value is None:
        return []
    if isinstance(value, (str, Path)):
        return [str(value)]
    return [str(v) for v in value]
