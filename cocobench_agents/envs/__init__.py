"""CoCoBench for training: the benchmark as a PettingZoo environment (`parallel_env`, `env`),
a single-learner Gymnasium environment (`SeatEnv`) and TRL's environment contract
(`CoCoBenchTRLEnv`). Needs the ``env`` extra (``pip install -e '.[env]'``); see
docs/environments.md."""

from cocobench_agents.envs.parallel import CoCoBenchParallelEnv, env, parallel_env
from cocobench_agents.envs.rewards import DEFAULT_WEIGHTS
from cocobench_agents.envs.seat_env import SeatEnv
from cocobench_agents.envs.seated import DONE, EnvError, SeatAction, SeatedEpisode
from cocobench_agents.envs.trl_env import CoCoBenchTRLEnv, trl_environment

__all__ = ["DEFAULT_WEIGHTS", "DONE", "CoCoBenchParallelEnv", "CoCoBenchTRLEnv", "EnvError",
           "SeatAction", "SeatEnv", "SeatedEpisode", "env", "parallel_env", "trl_environment"]
