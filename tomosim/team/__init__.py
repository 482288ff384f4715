"""A team of robots exploring together: periodic merging, shared maps, team coverage,
limited communication (:mod:`tomosim.team.comms`) and the known-poses bound
(:mod:`tomosim.team.oracle`). Every setting of a team is one
:class:`TeamConfig` (:mod:`tomosim.team.config`).

>>> from tomosim.team import TeamConfig, TeamSession
>>> from tomosim.worlds import generate_floorplan
>>> session = TeamSession(generate_floorplan(0), robots=3, config=TeamConfig(), rng=0)
>>> session.count, session.steps
(3, 0)
"""

from tomosim.frames import frame_errors
from tomosim.team.comms import CommsConfig, in_range, reach_groups
from tomosim.team.config import TeamConfig, TrackingParams
from tomosim.team.coverage import TeamCoverage
from tomosim.team.merger import (
    PairEstimator,
    PairOutcome,
    TeamMerge,
    TeamMerger,
    pair_name,
    pair_order,
    robot_name,
)
from tomosim.team.oracle import ORACLE, check_team_method, oracle_estimator, team_methods
from tomosim.team.quality import (
    PairQuality,
    RoundQuality,
    merged_agreement,
    pair_quality,
    score_round,
    true_relative,
)
from tomosim.team.session import TeamSession
from tomosim.team.sharing import SharedMaps, grid_anchor, teammate_layer

__all__ = [
    "ORACLE",
    "CommsConfig",
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
    "TrackingParams",
    "check_team_method",
    "frame_errors",
    "grid_anchor",
    "in_range",
    "merged_agreement",
    "oracle_estimator",
    "pair_name",
    "pair_order",
    "pair_quality",
    "reach_groups",
    "robot_name",
    "score_round",
    "team_methods",
    "teammate_layer",
    "true_relative",
]
