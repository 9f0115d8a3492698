"""The Python API: `evaluate` runs exactly what `cocobench run` runs, into the same run folder,
and returns the episode results; `score` and `report` do what their commands do."""

from __future__ import annotations

import asyncio
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import click

#: `run_options` that `evaluate` sets from its own arguments.
_OWN = frozenset({"tasks", "suite", "models", "conditions", "planner", "planners", "obs_mode",
                  "prompt_suite", "prompt_suites", "out"})


class EvaluationError(ValueError):
    """What `cocobench run` would report as a mistake (exit 2): a bad option, an unusable
    task config, model or run folder (the original error is its ``__cause__``)."""


class EvalResults(list):
    """The result lines of a run (one dict per episode, the fields of ``results.jsonl``).

    `folder` is the run folder; `errors` counts episodes that the model's infrastructure or
    the harness ended; `stopped` says why the run did not finish every episode (a spend
    limit), or is None.
    """

    def __init__(self, records: list[dict[str, Any]], folder: Path, errors: int,
                 stopped: str | None) -> None:
        super().__init__(records)
        self.folder, self.errors, self.stopped = folder, errors, stopped


def evaluate(source: str | Path | Sequence[str | Path] | None = None, *,
             models: str | Sequence[str], out: str | Path,
             conditions: str | Sequence[str] = "C0_image",
             planners: Sequence[str] | None = None,
             prompt_suites: Sequence[str] | None = None,
             **run_options: Any) -> EvalResults:
    """Run `models` on the instances of `source` (a suite name, config file or folder, index or
    subset file; several for several; default cocobench-240) under `conditions`, into the run
    folder `out`, as ``cocobench run`` does; return the results of every planned episode.

    `planners` (names, ``FILE.py:NAME`` or ``module:NAME``) run each planner under the
    observation modes of `conditions`; `prompt_suites` (names or folders, ``+variant``s) are
    arms crossed with models and conditions. Any other option of ``cocobench run`` is a
    keyword: ``max_steps=10``, ``resume=True``, ``jobs=4``, ``api_base="http://…"``.
    """
    from cocobench_agents.cli import is_user_error
    from cocobench_agents.cli.run_cmd import run_command
    from cocobench_agents.graphs.plugins import forget_user_planners

    forget_user_planners()  # a strategy file edited since the last call is read afresh

    argv = run_arguments(source, models=models, out=out, conditions=conditions,
                         planners=planners, prompt_suites=prompt_suites,
                         options=run_options, command=run_command)
    stopped = None
    try:
        run_command.main(args=argv, prog_name="cocobench run", standalone_mode=False)
    except click.ClickException as exc:
        if exc.exit_code == 3:  # a spend limit: what ran is recorded
            stopped = exc.format_message()
        elif exc.exit_code != 1:  # 1: episodes ended on errors, counted below
            raise EvaluationError(exc.format_message()) from None
    except click.exceptions.Exit as exc:
        if exc.exit_code:
            raise EvaluationError(f"cocobench run exited with {exc.exit_code}") from None
    except Exception as exc:
        if not is_user_error(exc):
            raise
        raise EvaluationError(str(exc)) from exc  # the error the command reports, exit 2
    return collect_results(Path(out), stopped)


async def evaluate_async(source: str | Path | Sequence[str | Path] | None = None,
                         **kwargs: Any) -> EvalResults:
    """`evaluate` for code already inside an event loop (notebooks): it runs on a thread,
    which runs its own event loop."""
    return await asyncio.to_thread(evaluate, source, **kwargs)


def run_arguments(source: Any, *, models: Any, out: Any, conditions: Any, planners: Any,
                  prompt_suites: Any, options: dict[str, Any],
                  command: click.Command) -> list[str]:
    """The ``cocobench run`` arguments that `evaluate` stands for."""
    params = {p.name: p for p in command.params if isinstance(p, click.Option)}
    argv = ["--out", str(out)]
    for model in _listed(models):
        argv += ["--model", model]
    sources = _listed(source)
    if len(sources) == 1:
        argv += ["--suite", sources[0]]
    for path in sources if len(sources) > 1 else []:
        argv += ["--task", path]
    names = [c for part in _listed(conditions) for c in part.split(",") if c]
    if planners:  # planner arms: each planner under the observation modes of `conditions`
        for planner in _listed(planners):
            argv += ["--planner", planner]
        for mode in dict.fromkeys(c.rpartition("_")[2] for c in names):
            argv += ["--obs", mode]
    else:
        argv += ["--conditions", ",".join(names)]
    for suite in _listed(prompt_suites):
        argv += ["--prompt-suite", suite]
    for name, value in options.items():
        if name in _OWN or name not in params:
            raise TypeError(f"evaluate() has no option {name!r} (see `cocobench run --help`)")
        argv += _option(params[name], value)
    return argv


def collect_results(out: Path, stopped: str | None = None) -> EvalResults:
    """The latest result line of every episode recorded in run folder `out`."""
    from cocobench_agents.harness import RunFolder
    from cocobench_agents.harness.infra import count_infra_failures
    from cocobench_agents.harness.summary import latest

    records = latest(RunFolder(out).results())
    errors = count_infra_failures(records)
    if errors:
        warnings.warn(f"{errors} episodes of {out} ended on infrastructure errors; re-run "
                      "them with evaluate(..., resume=True, retry_errors=True)", stacklevel=3)
    return EvalResults(records, out, errors, stopped)


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


def _option(param: click.Option, value: Any) -> list[str]:
    flag = max(param.opts, key=len)
    if param.is_flag:
        return [flag] if value else []
    if value is None:
        return []
    values = value if param.multiple and not isinstance(value, str) else [value]
    return [part for v in values for part in (flag, str(v))]
