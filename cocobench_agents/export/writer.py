"""Writing the rows as Parquet, in batches (an export of a large run never holds all its rows,
frames included, in memory), into an output folder that must be new or empty."""

from __future__ import annotations

import itertools
import os
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

from cocobench_agents.export.columns import arrow_schema
from cocobench_agents.export.errors import ExportError, ExportWriteError

#: The data file, where the Hub's and `datasets`' conventions look for a `train` split.
DATA_FILE = "data/train-00000-of-00001.parquet"
#: Rows per Parquet row group (and per batch held in memory).
BATCH_ROWS = 256
INSTALL = "pip install 'cocobench-agents[export]'"


def require_pyarrow() -> None:
    """`ExportError` naming the install command when pyarrow is missing."""
    try:
        import pyarrow.parquet  # noqa: F401
    except ImportError:
        raise ExportError(f"cocobench export writes Parquet with pyarrow, which is not "
                          f"installed: {INSTALL}") from None


def check_out(out: Path) -> None:
    """Refuse an output path that is a file or a folder holding anything (as `cocobench view
    --export` does): an export never mixes with, nor overwrites, other files."""
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise ExportError(f"{out}: the output folder exists and is not empty (choose a new "
                          "one)")


def write_rows(rows: Iterable[dict[str, Any]], path: Path) -> int:
    """Write `rows` to the Parquet file `path` (through a temporary file, renamed when
    complete); return how many were written."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    schema = arrow_schema()
    temporary = path.with_name(f".{path.name}.partial")
    count = 0
    try:
        with pq.ParquetWriter(temporary, schema) as writer:
            for batch in _batches(rows, BATCH_ROWS):
                writer.write_table(pa.Table.from_pylist(batch, schema=schema))
                count += len(batch)
        os.replace(temporary, path)
    except (pa.ArrowInvalid, pa.ArrowTypeError) as exc:  # a value no column can hold
        raise ExportError(f"a decision does not fit the dataset's columns: {exc}") from None
    except OSError as exc:
        raise ExportWriteError(f"cannot write {path}: {exc.strerror or exc}") from None
    finally:
        temporary.unlink(missing_ok=True)
    return count


def _batches(rows: Iterable[dict[str, Any]], size: int) -> Iterator[list[dict[str, Any]]]:
    iterator = iter(rows)
    while batch := list(itertools.islice(iterator, size)):
        yield batch
