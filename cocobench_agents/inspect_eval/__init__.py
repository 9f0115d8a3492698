"""CoCoBench as an Inspect task: ``inspect eval cocobench_agents/cocobench`` runs the episodes
`cocobench run` runs (the same runner, planners, prompts and parsing) with the decisions made
by Inspect's model, and scores them as our result lines (docs/inspect.md).

Needs ``pip install 'cocobench-agents[inspect]'``; the package's modules import `inspect_ai`.
Only Inspect (the ``inspect_ai`` entry point names this package: importing it registers the
task) and ``cocobench import-inspect`` import the package: ``import cocobench_agents`` never
loads Inspect.
"""

from .offline import use_bundled_tokenizer

use_bundled_tokenizer()  # before Inspect counts a token: the docs' first command runs offline

from .task import cocobench  # noqa: E402 - after the tokenizer's folder is set

__all__ = ["cocobench"]
