"""What holds whether or not the inspect extra is installed: importing the package, its
models (the ``inspect`` transport among them) and its Python API never imports `inspect_ai`;
`cocobench run` refuses the ``inspect`` transport, which only an Inspect eval can use."""

from __future__ import annotations

import subprocess
import sys

import pytest

from cocobench_agents.api import EvaluationError, evaluate

from .conftest import subprocess_env


def test_importing_cocobench_agents_does_not_import_inspect():
    code = ("import sys, cocobench_agents, cocobench_agents.models.pool, "
            "cocobench_agents.models.inspect_client, cocobench_agents.api, "
            "cocobench_agents.cli; "
            "assert 'inspect_ai' not in sys.modules, 'inspect_ai was imported'")
    subprocess.run([sys.executable, "-c", code], check=True, env=subprocess_env())


def test_cocobench_run_refuses_the_inspect_transport(tmp_path):
    with pytest.raises(EvaluationError, match="the inspect transport decides with the model "
                                              "of a running Inspect eval"):
        evaluate("demo", models="openai/gpt-4o", out=tmp_path / "run", transport="inspect",
                 limit=1)
    assert not (tmp_path / "run").exists()
