"""The task's pre-flight, as `cocobench run`'s (`models.preflight`): before any sample, one
cheap call per model the episodes call (Inspect's model, the model roles that decide for an
agent) and input kind (a tiny image under an image condition), with the settings the
decisions are sent with. An unknown model, a dead endpoint, a text-only model under an image
condition stop the eval there with the provider's words, exit 1, instead of failing every
sample after Inspect's retries.

The check runs where Inspect builds the task under ``inspect eval`` (and `eval()` given the
task's name or function): the eval's model and roles are known there, and a
`TaskParameterError` ends the command with its message alone. Inspect builds the task inside
its event loop, so the calls go through their own loop in a worker thread, each through its
own `Model` instance (not the eval's, whose connections belong to Inspect's loop), with one
attempt and the probe's small token cap. A task built before the eval (``eval(cocobench(…))``
from Python) has no model to check yet: it runs as it is.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
from collections.abc import Iterable
from typing import Any

from benchmark_adapter.tasks import TaskConfig
from benchmark_adapter.vocabulary import IMAGE
from cocobench_agents.engine.resolve import unknown_seats
from cocobench_agents.graphs import NO_MODEL, planner_spec
from cocobench_agents.harness.episodes import PlannedEpisode
from cocobench_agents.models.inspect_client import InspectClient
from cocobench_agents.models.preflight import probe_request, probe_settings
from cocobench_agents.models.protocol import ModelError
from cocobench_agents.models.secrets import redact
from cocobench_agents.models.settings import ModelSettings, unset_sampling_notice

#: Inspect's providers that call nothing remote: nothing to check.
LOCAL_PROVIDERS = ("mockllm/", "none/")
#: How long one probe may take in all (Inspect's ``--timeout`` when smaller).
PROBE_TIMEOUT_S = 60
#: What skips the check, as the message says.
SKIP = "-T preflight=false skips this check"


class PreflightFailed(ValueError):
    """A model that failed its pre-flight call (the message names it, with the provider's
    words)."""


def check_eval_models(settings: ModelSettings, planned: Iterable[PlannedEpisode]) -> None:
    """Probe the models of the running eval that `planned` calls; `PreflightFailed` naming
    each model and input kind whose call failed. Nothing when no eval is running here."""
    # Inspect (0.3.285) exports no way to ask for the running eval's model without falling
    # back to a default one (`get_model()`): its own `active_model` is read, here and below.
    from inspect_ai.model._model import active_model

    team = active_model()
    if team is None:  # a task built before its eval: no model yet
        return
    checks = _checks(team, list(planned))
    if not checks:
        return
    with concurrent.futures.ThreadPoolExecutor(1, thread_name_prefix="preflight") as pool:
        failures = pool.submit(asyncio.run, _probe_all(settings, checks)).result()
    failures = [failure for failure in failures if failure]
    if failures:
        raise PreflightFailed(f"pre-flight call failed (no sample was started; {SKIP}): "
                              + " | ".join(failures))


def check_roles(tasks: list[TaskConfig]) -> None:
    """`PreflightFailed` for an Inspect model role of the running eval that names no agent of
    `tasks` (a misspelt ``--model-role agnet_2=…`` would be ignored: that agent would decide
    with the eval's model), as `cocobench run` refuses such an ``--agent-model``."""
    from inspect_ai.model import model_roles

    unknown = unknown_seats(model_roles(), tasks)
    if unknown:
        raise PreflightFailed(f"--model-role {unknown}")


def sampling_notice(settings: ModelSettings, planned: Iterable[PlannedEpisode]) -> str | None:
    """`cocobench run`'s warning for the remote models of the running eval whose calls carry
    no temperature (neither ``-T temperature`` nor Inspect's ``--temperature`` sets one): the
    provider samples at its own default and the eval is not reproducible. None otherwise."""
    from inspect_ai.model._generate_config import active_generate_config
    from inspect_ai.model._model import active_model

    team = active_model()
    if team is None or active_generate_config().temperature is not None:
        return None
    models = [str(model) for model, _ in _checks(team, list(planned))]
    notice = unset_sampling_notice(settings, models)
    return notice.replace("--temperature ", "-T temperature=") if notice else None


def _checks(team: Any, planned: list[PlannedEpisode]) -> list[tuple[Any, bool]]:
    """(Inspect model, with an image) for each remote model the episodes call and input kind
    they send it."""
    from cocobench_agents.models.inspect_client import role_model

    kinds: dict[str, tuple[Any, set[bool]]] = {}
    for episode in planned:
        if episode.key.model == NO_MODEL:  # a planner that calls no model
            continue
        images = episode.spec.obs_mode == IMAGE
        models = [team]
        if planner_spec(episode.spec.planner).decentralized:
            models += [role_model(agent) for agent in episode.spec.config.agent_ids]
        for model in models:
            if model is not None and not str(model).startswith(LOCAL_PROVIDERS):
                kinds.setdefault(str(model), (model, set()))[1].add(images)
    return [(model, images) for model, modes in kinds.values() for images in sorted(modes)]


async def _probe_all(settings: ModelSettings, checks: list[tuple[Any, bool]]
                     ) -> list[str | None]:
    return list(await asyncio.gather(*(_probe(settings, model, images)
                                       for model, images in checks)))


async def _probe(settings: ModelSettings, model: Any, images: bool) -> str | None:
    """None when `model` answered, else what went wrong (the provider's words)."""
    from inspect_ai.model import get_model

    config = model.config.merge({"max_retries": 0})
    timeout = min(config.timeout or PROBE_TIMEOUT_S, PROBE_TIMEOUT_S)
    own = get_model(str(model), config=config.merge({"timeout": timeout}),
                    base_url=model.api.base_url, memoize=False, **model.model_args)
    client = InspectClient(str(model), probe_settings(settings).model_copy(
        update={"transport": "inspect", "max_retries": 0}), inspect_model=own)
    what = "with an image" if images else "text only"
    try:
        async with own:
            await asyncio.wait_for(client.complete(probe_request(images)), timeout)
    except ModelError as error:
        if error.kind == "empty":  # the provider answered: that is what matters here
            return None
        return redact(f"{model} ({what}): {error}", settings.secrets())
    except TimeoutError:
        return f"{model} ({what}): no answer within {timeout} s"
    return None
