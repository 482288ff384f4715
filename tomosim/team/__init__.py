"""A team of robots exploring together: periodic merging, shared maps, team coverage.

>>> from tomosim.team import TeamConfig, TeamSession
>>> from tomosim.worlds import generate_floorplan
>>> session = TeamSession(generate_floorplan(0), robots=3, config=TeamConfig(), rng=0)
>>> session.count, session.steps
(3, 0)
"""

from tomosim.team.coverage import TeamCoverage
from tomosim.team.merger import TeamMerge, TeamMerger
from tomosim.team.quality import (
    PairQuality,
    frame_errors,
    merged_agreement,
    pair_quality,
    robot_name,
    true_relative,
)
from tomosim.team.session import TeamConfig, TeamSession
from tomosim.team.sharing import SharedMaps, grid_anchor, teammate_layer

__all__ = [
    "PairQuality",
    "SharedMaps",
    "TeamConfig",
    "TeamCoverage",
    "TeamMerge",
    "TeamMerger",
    "TeamSession",
    "frame_errors",
    "grid_anchor",
    "merged_agreement",
    "pair_quality",
    "robot_name",
    "teammate_layer",
    "true_relative",
]
