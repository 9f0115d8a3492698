"""Where the tests find the real CoCoBench data: `../shared` beside the checkout."""

from pathlib import Path

SHARED_DATA = Path(__file__).resolve().parents[1].parent / "shared" / "cocobench-data"
SHARED_TASKS = SHARED_DATA / "tasks"
