"""`cocobench view --export DIR`: the same pages as a static folder any web server can host
(no live polling: the runs page shows the episodes recorded at export time)."""

from __future__ import annotations

import shutil
from pathlib import Path

from cocobench_agents.viewer.errors import ViewerError
from cocobench_agents.viewer.pages import Pages
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
    (out / "static").mkdir(parents=True, exist_ok=True)
    for name, static in static_files().items():
        (out / "static" / name).write_bytes(static.body)
    written = {"index.html": pages.runs()}
    episodes = pages.catalog.episodes()
    for episode in episodes:
        written[episode.path] = pages.episode(episode)
        _copy_frames(pages, episode, out)
    for task_id in dict.fromkeys(e.key.task_id for e in episodes):
        written[f"compare/{task_id}.html"] = pages.compare(task_id) or ""
    for relative, html in written.items():
        target = out / relative
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(html, encoding="utf-8")
    return len(written)


def _copy_frames(pages: Pages, episode: Episode, out: Path) -> None:
    run = pages.catalog.runs[episode.run]
    traj = run.trajectory(episode) or {}
    for item in traj.get("trajectory") or []:
        image = item.get("image") if isinstance(item, dict) else None
        if not isinstance(image, str) or image.startswith("data:"):
            continue
        source = run.file(image)  # None for a path or a link leading out of the run folder
        if source is not None:
            target = out / "files" / str(run.index) / image
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(source, target)
