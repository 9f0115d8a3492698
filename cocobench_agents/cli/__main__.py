"""`python -m cocobench_agents.cli`: the `cocobench` command."""

import sys

from cocobench_agents.cli import main

sys.exit(main())
