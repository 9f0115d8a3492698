"""Exporting in the tests: the command line in this process, and the run folder read
directly (its files, not the export's code) for what the rows must hold."""

from __future__ import annotations

import gzip
import json
from pathlib import Path
from typing import Any

import pytest

from cocobench_agents.cli import main

DATA = Path("data") / "train-00000-of-00001.parquet"


def export(capsys: pytest.CaptureFixture[str], *args: str | Path) -> tuple[int, str, str]:
    """`cocobench export ARGS`: its exit code, stdout and stderr."""
    capsys.readouterr()
    code = main(["export", *map(str, args)])
    out, err = capsys.readouterr()
    return code, out, err


def load(out: Path, cache: Path) -> Any:
    """The export as Hugging Face `datasets` loads it, as it is."""
    import datasets

    return datasets.load_dataset("parquet", data_files=str(out / DATA), split="train",
                                 cache_dir=str(cache))


def result_lines(run: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in (run / "results.jsonl").read_text().splitlines()]


def model_decisions(run: Path, line: dict[str, Any]) -> list[tuple[dict[str, Any], str]]:
    """An episode's decisions that called a model, each with the text of its kept prompt."""
    document = json.loads((run / line["trajectory"]).read_text())
    prompts_file = (run / line["trajectory"]).parent / "prompts.json.gz"
    prompts = json.loads(gzip.decompress(prompts_file.read_bytes()))
    return [(d, prompts[d["prompt_hash"]]) for d in document["planner_decisions"]
            if d.get("prompt_hash")]


def episode_of(row: dict[str, Any]) -> tuple[str, str, str]:
    return row["model"], row["condition"], row["task_id"]
