"""A team of robots exploring together: periodic merging, shared maps, team coverage.

>>> from tomosim.team import TeamConfig, TeamSession
>>> from tomosim.worlds import generate_floorplan
>>> session = TeamSession(generate_floorplan(0), robots=3, config=TeamConfig(), rng=0)
>>> session.count, session.steps
(3, 0)
"""

from tomosim.frames import frame_errors
from tomosim.team.coverage import TeamCoverage
from tomosim.team.merger import (
    PairEstimator,
    PairOutcome,
    TeamMerge,
    TeamMerger,
    pair_name,
    robot_name,
)
from tomosim.team.quality import (
    PairQuality,
    RoundQuality,
    merged_agreement,
    pair_quality,
    score_round,
    true_relative,
)
from tomosim.team.session import TeamConfig, TeamSession
from tomosim.team.sharing import SharedMaps, grid_anchor, teammate_layer

__all__ = [
    "PairEstimator",
    "PairOutcome",
    "PairQuality",
    "RoundQuality",
    "SharedMaps",
    "TeamConfig",
    "TeamCoverage",
    "TeamMerge",
    "TeamMerger",
    "TeamSession",
    "frame_errors",
    "grid_anchor",
    "merged_agreement",
    "pair_name",
    "pair_quality",
    "robot_name",
    "score_round",
    "teammate_layer",
    "true_relative",
]
