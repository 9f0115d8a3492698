"""Every checker of the ecosystem passes with the environments' defaults, for every built-in
condition, blind and image: Gymnasium's `check_env` (through `gymnasium.make`, so its render
modes are checked too), PettingZoo's `parallel_api_test`, `api_test`, `parallel_seed_test`
and `seed_test`, and Gymnasium's `SyncVectorEnv` and `AsyncVectorEnv` (default shared
memory). They sample the action spaces unmasked, as RL libraries explore: every element of an
action space is a valid action. The same for a plugin planner (claim-board, installed from
examples/claim-board with an entry point) and for the numeric observation."""

from __future__ import annotations

import numpy as np
import pytest

from tests.paths import SHARED_TASKS

pytestmark = [pytest.mark.needs_env, pytest.mark.slow, pytest.mark.usefixtures("quiet")]

TASKS = str(SHARED_TASKS)
REAL = "A_D1__FloorPlan1__seed0"  # agents agent_1, agent_2
CONDITIONS = [f"{code}_{mode}" for mode in ("blind", "image")
              for code in ("C0", "D0", "D1", "LW", "CL")]
#: The learning seat `check_env` and the vector environments play, per planner code.
SEATS = {"C0": "team", "D0": "agent_1", "D1": "agent_2", "LW": "agent_1", "CL": "agent_1"}


@pytest.mark.parametrize("observation", ["text", "numeric"])
@pytest.mark.parametrize("condition", CONDITIONS)
def test_every_checker_passes_with_the_defaults(condition, observation):
    import gymnasium
    from gymnasium.utils.env_checker import check_env
    from pettingzoo.test import api_test, parallel_api_test, parallel_seed_test, seed_test

    from cocobench_agents.envs import SEAT_ENV_ID, env, parallel_env

    if condition.startswith("CL"):
        claim_board()
    cycles = 10 if condition.endswith("image") else 40  # (an image step draws frames)
    settings = {"source": TASKS, "condition": condition, "task_id": REAL}
    if observation != "text":  # (the default is left unnamed: the defaults are checked)
        settings["observation"] = observation
    seats = [SEATS[condition[:2]], *(["leader"] if condition.startswith("LW") else [])]
    for seat in seats:
        # No render mode (the default): check_env makes every declared one through the spec.
        made = gymnasium.make(SEAT_ENV_ID, seat=seat, partner="random", **settings)
        check_env(made.unwrapped)
        made.close()
    parallel_api_test(parallel_env(**settings), num_cycles=cycles)
    api_test(env(**settings), num_cycles=cycles)
    parallel_seed_test(lambda: parallel_env(**settings), num_cycles=cycles)
    seed_test(lambda: env(**settings), num_cycles=cycles)
    # Async holds the observations in shared memory: they are the same as Sync's.
    seen = play_vector(gymnasium.vector.SyncVectorEnv, condition, settings)
    assert all(seen[0]) and seen == play_vector(gymnasium.vector.AsyncVectorEnv, condition,
                                                settings)


def claim_board() -> None:
    """Skip where claim-board's example package is not installed."""
    from cocobench_agents.graphs import find_planner

    if find_planner("CL") is None:
        pytest.skip("examples/claim-board is not installed (pip install -e examples/claim-board)")


def play_vector(vector_class, condition: str, settings: dict) -> list[tuple]:
    """What the two seat environments under `vector_class` observe over a few steps (their
    prompts; under the numeric observation, their object and goal tables), played with
    seeded unmasked samples."""
    import gymnasium

    from cocobench_agents.envs import SEAT_ENV_ID

    def make():
        return gymnasium.make(SEAT_ENV_ID, seat=SEATS[condition[:2]], partner="random",
                              **settings)

    vector = vector_class([make, make])
    try:
        vector.action_space.seed(0)
        observations, _ = vector.reset(seed=[1, 2])
        assert observations["action_mask"].dtype == np.int8
        seen = [seen_by(observations)]
        for _ in range(3):
            observations, rewards, *_ = vector.step(vector.action_space.sample())
            assert rewards.shape == (2,)
            seen.append(seen_by(observations))
        return seen
    finally:
        vector.close()


def seen_by(observations: dict) -> tuple:
    """Each environment's prompt, or its object and goal tables as bytes."""
    if "prompt" in observations:
        return tuple(observations["prompt"])
    return tuple(observations["objects"][i].tobytes() + observations["goal"][i].tobytes()
                 for i in range(len(observations["objects"])))
