"""Which episodes of a plan are still to run."""

from __future__ import annotations

from collections.abc import Sequence

from cocobench_agents.harness.episodes import PlannedEpisode
from cocobench_agents.runfolder.folder import RunFolder
from cocobench_agents.runfolder.infra import is_infra_failure


def pending_episodes(episodes: Sequence[PlannedEpisode], folder: RunFolder, *,
                     retry_errors: bool = False) -> list[PlannedEpisode]:
    """The planned episodes without a valid result line and trajectory (plus infrastructure
    failures, when asked: see `is_infra_failure`). An episode whose latest line is invalid
    or whose trajectory is missing counts as not done (`RunFolder.scan_results`)."""
    done = folder.scan_results(check_trajectories=True).done
    return [p for p in episodes
            if p.key not in done or (retry_errors and is_infra_failure(done[p.key]))]
