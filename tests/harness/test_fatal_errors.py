"""A fatal provider error (the key refused, no such model) stops a run from starting episodes,
in this process and in worker processes: the episodes in flight finish and are recorded as
today, then `FatalModelError` names the model and the error. Transient errors (429, 5xx) keep
their retries and never stop a run."""

from __future__ import annotations

import pickle

import pytest

from benchmark_adapter.tasks import load_tasks
from cocobench_agents.harness import (
    Condition,
    ExecutionSettings,
    InProcess,
    WorkerProcesses,
    plan_episodes,
)
from cocobench_agents.harness.errors import (
    FatalModelError,
    WorkerEnvironmentError,
    WorkersLost,
    fatal_model_error,
)
from cocobench_agents.models import ModelPool, ModelSettings
from cocobench_agents.runfolder import RunFolder
from tests.models.fake_openai import RATE_LIMITED, SERVER_ERROR, FakeOpenAI, error, ok

MODEL = "openai/fake"
EPISODES = 12
JOBS = 2
UNAUTHORIZED = error(401, "Incorrect API key provided", code="invalid_api_key",
                     err_type="invalid_request_error")
NO_SUCH_MODEL = error(404, "The model `fake` does not exist", code="model_not_found",
                      err_type="invalid_request_error")


@pytest.fixture(scope="module")
def server():
    with FakeOpenAI() as fake:
        yield fake


def plan():
    return plan_episodes(load_tasks("cocobench-240")[:EPISODES], [MODEL],
                         [Condition("centralized", "blind")], 1, max_steps=3)


def settings(server: FakeOpenAI) -> ModelSettings:
    return ModelSettings(api_base=server.base_url, transport="http", timeout_s=10,
                         max_retries=1, backoff_s=0.01, backoff_max_s=0.01)


def new_folder(path) -> RunFolder:
    folder = RunFolder(path)
    folder.create({"name": path.name})
    return folder


def run_locally(folder: RunFolder, server: FakeOpenAI) -> None:
    InProcess().run(plan(), folder, ModelPool(settings(server)), ExecutionSettings(jobs=JOBS))


def run_in_workers(folder: RunFolder, server: FakeOpenAI) -> None:
    WorkerProcesses().run(plan(), folder, ModelPool(settings(server)),
                          ExecutionSettings(jobs=JOBS, workers=2))


@pytest.mark.parametrize("execute", [run_locally, run_in_workers], ids=["asyncio", "workers"])
@pytest.mark.parametrize(("answer", "kind"), [(UNAUTHORIZED, "auth"),
                                              (NO_SUCH_MODEL, "not_found")])
def test_a_fatal_model_error_stops_the_run_after_the_episodes_in_flight(
        server, tmp_path, execute, answer, kind):
    server.program(default=answer)
    folder = new_folder(tmp_path / "run")
    with pytest.raises(FatalModelError) as stopped:
        execute(folder, server)
    error = stopped.value
    assert (error.model, error.kind) == (MODEL, kind)
    assert str(error).startswith(f"{MODEL}: the provider ")
    assert str(answer.status) in error.detail and "stopped starting episodes" in str(error)
    records = list(folder.results())
    # Only the episodes in flight when the first fatal error came back (every call fails):
    # an episode's own fatal error stops its worker before it starts another.
    assert 1 <= len(records) <= JOBS
    assert all(r["backend_errors"] > 0 and not r.get("infra_error") for r in records)
    assert server.count == sum(r["usage"]["model_calls"] for r in records)


@pytest.mark.parametrize("answer", [RATE_LIMITED, SERVER_ERROR], ids=["429", "500"])
def test_transient_errors_are_retried_and_never_stop_the_run(server, tmp_path, answer):
    server.program(answer, default=ok())  # the first call fails once, its retry succeeds
    folder = new_folder(tmp_path / "retried")
    run_locally(folder, server)
    assert len(list(folder.results())) == EPISODES
    server.program(default=answer)  # every call fails, retries exhausted: errors, not a stop
    folder = new_folder(tmp_path / "failing")
    run_locally(folder, server)
    records = list(folder.results())
    assert len(records) == EPISODES and all(r["backend_errors"] > 0 for r in records)


def test_every_decision_of_an_episode_with_backend_errors_is_read():
    refused = {"status": "backend_error", "error_kind": "auth", "model": "openai/other",
               "error": "auth: refused"}
    # A heterogeneous team: the agent whose model refused the key idled (its decision is on
    # no step, so the episode's own backend_errors is 0), the others acted.
    document = {"trajectory": [], "planner_decisions": [{"status": "action"}, refused]}
    found = fatal_model_error({"backend_errors": 0, "usage": {"backend_errors": 1}}, document)
    assert found is not None and (found.model, found.kind) == ("openai/other", "auth")
    assert fatal_model_error({"backend_errors": 1}, None) is None  # it could not run
    assert fatal_model_error({"backend_errors": 0, "usage": {"backend_errors": 0}},
                             document) is None  # not read: a clean episode costs nothing
    timeout = {**refused, "error_kind": "timeout"}
    assert fatal_model_error({"backend_errors": 1},
                             {"planner_decisions": [timeout]}) is None


@pytest.mark.parametrize("error", [
    FatalModelError(MODEL, "auth", "auth: refused"),
    WorkerEnvironmentError(["OPENAI_API_KEY"], "ab12", "host-1"),
    WorkersLost(300.0, 7, "the nodes that ran them are gone"),
])
def test_the_stops_cross_process_boundaries_whole(error):
    copy = pickle.loads(pickle.dumps(error))
    assert type(copy) is type(error) and str(copy) == str(error)
    assert vars(copy) == vars(error)
