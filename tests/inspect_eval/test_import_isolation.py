"""The inspect extra is optional: importing the package, its models (the ``inspect``
transport among them) and its Python API never imports `inspect_ai`."""

from __future__ import annotations

import subprocess
import sys

from .conftest import subprocess_env


def test_importing_cocobench_agents_does_not_import_inspect():
    code = ("import sys, cocobench_agents, cocobench_agents.models.pool, "
            "cocobench_agents.models.inspect_client, cocobench_agents.api, "
            "cocobench_agents.cli; "
            "assert 'inspect_ai' not in sys.modules, 'inspect_ai was imported'")
    subprocess.run([sys.executable, "-c", code], check=True, env=subprocess_env())
