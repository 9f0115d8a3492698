"""The dataset card (README.md beside the data): what produced the rows (the runs, their
command, models, conditions, prompt suites and the settings that shaped each model's
episodes, as each run's `run.json` records them), what was selected and left out, the columns,
and how to load it. Everything in it comes from the run folders, redacted as the rows are."""

from __future__ import annotations

import json
import re
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from cocobench_agents.export.columns import COLUMNS
from cocobench_agents.export.decisions import EpisodeStats, Redactor
from cocobench_agents.export.runs import Run
from cocobench_agents.export.writer import DATA_FILE
from cocobench_agents.models.secrets import redact_named
from cocobench_agents.reports.arms import recorded_settings, row_settings
from cocobench_agents.version import __version__

#: What the card says of the licence: the benchmark's data states none that it could name.
LICENCE_NOTE = ("The CoCoBench task data these episodes were played on states no licence "
                "(none ships with it); ask its authors before redistributing this dataset. "
                "cocobench-agents, which wrote it, is Apache-2.0.")


#: The folders of an absolute local path (POSIX, home or Windows; not a URL's path), which the
#: card leaves out: they say where the data sat on the exporter's machine, nothing a reader
#: can use, and may name its user.
_LOCAL_FOLDERS = re.compile(r"(?<![\w:/.~-])(?:~|[A-Za-z]:)?[/\\](?:[^\s`'\"/\\]+[/\\])+"
                            r"(?=[^\s`'\"/\\])")


@dataclass(frozen=True)
class CardFacts:
    """What an export did, for its card."""

    runs: Sequence[Run]
    selection: str
    exported: Sequence[tuple[Run, Mapping[str, Any]]]  # (run, result line) of each episode
    stats: EpisodeStats
    left_out: Sequence[str]  # one line per kind of episode not exported, with its count


def dataset_card(facts: CardFacts, redact: Redactor) -> str:
    """The card's Markdown, with the YAML header the Hub and `datasets.load_dataset(DIR)`
    read (one `train` split: the data file)."""
    parts = [_header(), _summary(facts), *(_run_section(run, facts) for run in facts.runs),
             _selection(facts), _columns(), _images(facts.stats), _loading(),
             f"## Licence\n\n{LICENCE_NOTE}\n"]
    # the whole card redacted as each row, and local paths shown by their last part only
    return without_local_folders(redact("\n".join(parts)))


def without_local_folders(text: str) -> str:
    """`text` with each absolute local path cut to its last part (``/home/me/runs/r1`` →
    ``r1``)."""
    return _LOCAL_FOLDERS.sub("", text)


def _header() -> str:
    return ("---\nconfigs:\n- config_name: default\n  data_files:\n  - split: train\n"
            f"    path: {DATA_FILE}\ntags:\n- cocobench\n- multi-agent\n- embodied-planning\n"
            "- trajectories\n---\n")


def _summary(facts: CardFacts) -> str:
    names = ", ".join(f"`{run.name}`" for run in facts.runs)
    return (f"# CoCoBench decisions: {names}\n\n"
            f"One row per model decision of {facts.stats.episodes} episodes "
            f"({facts.stats.rows} decisions) of {len(facts.runs)} CoCoBench run(s), written by "
            f"`cocobench export` (cocobench-agents {__version__}). Each row holds the chat "
            "messages exactly as the model got them, its reply, the parsed action and whether "
            "it was legal and landed, the seat, and the episode's outcome and construct "
            "score.\n")


def _run_section(run: Run, facts: CardFacts) -> str:
    record = run.record
    request, _ = recorded_settings(record)  # the run's options, in either run.json layout
    plan = record.get("plan") if isinstance(record.get("plan"), Mapping) else {}
    budget = request.get("max_steps") or "each instance's own"
    lines = [f"## Run `{run.name}`", "",
             f"- created: {record.get('created_at', 'not recorded')}, by cocobench-agents "
             f"{record.get('cocobench_agents', '?')}",
             f"- command (local paths by their last part): "
             f"`{record.get('command', 'not recorded')}`",
             f"- backend: {request.get('backend', 'not recorded')}; epochs: "
             f"{request.get('epochs', 1)}; step budget: {budget}",
             f"- models: {', '.join(map(str, plan.get('models') or [])) or 'not recorded'}",
             f"- conditions: {', '.join(map(str, plan.get('conditions') or []))}",
             f"- instances: {len(plan.get('task_ids') or [])}"]
    if request.get("agent_models"):
        lines.append(f"- seat models: {_json(request['agent_models'])}")
    for model, arm in dict.fromkeys((str(line.get("model")), str(line.get("arm") or ""))
                                    for r, line in facts.exported if r is run):
        label = f"{model} @{arm}" if arm else model
        lines.append(f"- settings of `{label}`: {_json(row_settings(record, model, arm))}")
    lines += ["", "| model | condition | episodes | success |", "|---|---|---|---|"]
    counts = Counter((str(line.get("model")), str(line.get("condition")))
                     for r, line in facts.exported if r is run)
    wins = Counter((str(line.get("model")), str(line.get("condition")))
                   for r, line in facts.exported if r is run and line.get("task_success"))
    lines += [f"| {m} | {c} | {n} | {wins[m, c]}/{n} |" for (m, c), n in sorted(counts.items())]
    return "\n".join(lines) + "\n"


def _json(value: Any) -> str:
    return f"`{json.dumps(redact_named(value), sort_keys=True, default=str)}`"


def _selection(facts: CardFacts) -> str:
    lines = ["## Selection", "", f"- episodes kept: {facts.selection}"]
    lines += [f"- left out: {note}" for note in facts.left_out] or ["- left out: none"]
    if facts.stats.without_prompt:
        lines.append(f"- {facts.stats.without_prompt} decisions have no `messages`: their run "
                     "did not keep prompts (written before prompts were kept)")
    lines.append("- rows are the decisions that called a model; a stop record (step budget "
                 "reached, empty menu) sent no prompt and is not a row")
    return "\n".join(lines) + "\n"


def _columns() -> str:
    rows = "\n".join(f"| `{name}` | {kind} | {meaning} |" for name, kind, meaning in COLUMNS)
    return f"## Columns\n\n| column | type | meaning |\n|---|---|---|\n{rows}\n"


def _images(stats: EpisodeStats) -> str:
    if stats.with_image:
        return (f"## Images\n\n{stats.with_image} of {stats.rows} rows have an `image`: the "
                "frame the run kept for the state the decision was asked in.\n")
    return ("## Images\n\nNo row has an `image`: these runs kept no frames (cocobench's "
            "harness records decisions and prompts, not frames; blind conditions send none). "
            "The column is present, and null, so that exports of runs that kept frames load "
            "with the same features.\n")


def _loading() -> str:
    return ("## Loading\n\n```python\nimport datasets\n\n"
            f'rows = datasets.load_dataset("parquet", data_files="{DATA_FILE}", '
            'split="train")\n```\n\n'
            "or `datasets.load_dataset(\"PATH/TO/THIS/FOLDER\", split=\"train\")`.\n")
