"""`cocobench run --executor ray`: the options and the dispatch to the Ray executor.

Nothing here imports Ray: `--help` and option mistakes never pay for it.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import click

from cocobench_agents.harness.batch import ResultCallback
from cocobench_agents.harness.plan import PlannedEpisode
from cocobench_agents.harness.store import RunFolder
from cocobench_agents.models import ModelSettings

EXECUTORS = ("local", "ray")


class RayUsageError(click.ClickException):
    """Ray missing, or a cluster that cannot run the request: exit code 2."""

    exit_code = 2


def executor_options(command: Callable) -> Callable:
    """--executor / --ray-address / --thor-gpus-per-worker."""
    for option in reversed([
        click.option("--executor", type=click.Choice(EXECUTORS), default="local",
                     show_default=True,
                     help="Where episodes run: this process (and --workers processes), or "
                          "Ray workers on this machine or a cluster (pip install "
                          "'cocobench-agents[ray]'; see docs/distributed.md). With ray, "
                          "--workers counts Ray workers (default: as many as fit).",),
        click.option("--ray-address", default=None, metavar="HOST:PORT",
                     help="With --executor ray: join the cluster whose head is there "
                          "(default: start a private local Ray)."),
        click.option("--thor-gpus-per-worker", type=click.FloatRange(min=0), default=0.25,
                     show_default=True,
                     help="With --executor ray --backend ai2thor: the GPU share of each "
                          "worker (one Unity each); 0 for CPU nodes."),
    ]):
        command = option(command)
    return command


def check_executor_options(kw: dict[str, Any]) -> None:
    """Mistakes in the executor options, before anything is recorded."""
    if kw["executor"] != "ray":
        for name in ("ray_address", "thor_gpus_per_worker"):
            if _given(name):
                flag = "--" + name.replace("_", "-")
                raise click.UsageError(f"{flag} needs --executor ray")
        return
    from cocobench_agents.harness.ray_session import RayUnavailable, check_reachable, require_ray

    try:
        require_ray()
        if kw["ray_address"]:
            check_reachable(kw["ray_address"])
    except RayUnavailable as exc:
        raise RayUsageError(str(exc)) from None


def run_on_ray(kw: dict[str, Any], episodes: Sequence[PlannedEpisode], folder: RunFolder,
               settings: ModelSettings, on_result: ResultCallback,
               **run_options: Any) -> None:
    """Run `episodes` with the Ray executor as the options ask (`run_options`: the spend
    limit and the episode timeout, as for the local executor)."""
    from cocobench_agents.harness.ray_executor import RayOptions, execute_on_ray
    from cocobench_agents.harness.ray_local import LocalRayError
    from cocobench_agents.harness.ray_session import RayUnavailable

    options = RayOptions(address=kw["ray_address"],
                         workers=kw["workers"] if _given("workers") else 0,
                         thor_gpus_per_worker=kw["thor_gpus_per_worker"])
    where = kw["ray_address"] or "a local Ray"
    try:
        execute_on_ray(episodes, folder, settings, jobs=kw["jobs"], options=options,
                       on_result=on_result, **run_options,
                       on_start=lambda shape: click.echo(f"{shape.describe()} on {where}",
                                                         err=True))
    except RayUnavailable as exc:
        raise RayUsageError(str(exc)) from None
    except LocalRayError as exc:
        raise click.ClickException(str(exc)) from None


def _given(name: str) -> bool:
    """Whether the option was given on the command line (not left at its default)."""
    context = click.get_current_context(silent=True)
    if context is None:
        return False
    source = context.get_parameter_source(name)
    return source is not None and source != click.core.ParameterSource.DEFAULT
