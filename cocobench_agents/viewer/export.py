"""`cocobench view --export DIR`: the same pages as a static folder any web server can host
(no live polling: the runs page shows the episodes recorded at export time)."""

from __future__ import annotations

import shutil
from pathlib import Path

from cocobench_agents.viewer.errors import ViewerError
from cocobench_agents.viewer.pages import Pages
from cocobench_agents.viewer.paths import inside, path_part
from cocobench_agents.viewer.rows import compare_path
from cocobench_agents.viewer.server import static_files
from cocobench_agents.viewer.source import Episode


def export(pages: Pages, out: Path) -> int:
    """Write every page, the static assets and the frames the trajectories name into `out`
    (which must be new or empty); return the number of pages written."""
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise ViewerError(f"{out}: export folder exists and is not empty (choose a new one)")
    try:
        return _write(pages, out)
    except OSError as exc:
        raise ViewerError(f"cannot write the export to {out}: {exc.strerror or exc}") from None


def _write(pages: Pages, out: Path) -> int:
    for name, static in static_files().items():
        _write_file(out, f"static/{path_part(name)}", static.body)
    written = {"index.html": pages.runs()}
    episodes = pages.catalog.episodes()
    for episode in episodes:
        written[episode.path] = pages.episode(episode)
        _copy_frames(pages, episode, out)
    for task_id in dict.fromkeys(e.key.task_id for e in episodes):
        written[compare_path(task_id)] = pages.compare(task_id) or ""
    for relative, html in written.items():
        _write_file(out, relative, html.encode("utf-8"))
    return len(written)


def _write_file(out: Path, relative: str, data: bytes) -> None:
    """Write `data` at `relative` in `out`, checked to resolve inside it first."""
    target = inside(out, relative)
    target.parent.mkdir(parents=True, exist_ok=True)
    target.write_bytes(data)


def _copy_frames(pages: Pages, episode: Episode, out: Path) -> None:
    """Copy the frames the episode's trajectory names, each to `files/RUN/` and its path
    inside the run folder (`RunSource.relative`: where its page links to it)."""
    run = pages.catalog.runs[episode.run]
    traj = run.trajectory(episode) or {}
    items = traj.get("trajectory")
    for item in items if isinstance(items, list) else []:
        image = item.get("image") if isinstance(item, dict) else None
        if not isinstance(image, str) or image.startswith("data:"):
            continue
        relative = run.relative(image)  # None for a path or a link leading out of the run
        source = run.file(image)
        if relative is not None and source is not None:
            target = inside(out, f"files/{run.index}/{relative}")
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(source, target)
