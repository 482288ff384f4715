"""The entity tree of a tomosim recording, and its timelines.

::

    run/config                         static: the run's settings (JSON text)
    run/status                         static, rewritten: "running", then how the run
                                       ended ("finished at step 867: ...", "interrupted
                                       at step 340: ..."); a recording that still says
                                       "running" was cut off (process killed)
    world                              static: the world frame, mirrored in y for rerun's
                                       2-D views (they draw y down; the world's y is up)
    world/truth                        static: the ground-truth grid (SegmentationImage
                                       of ROS cell values, placed by its Transform3D)
    world/walls                        static: the wall segments
    world/robots/r0                    the true pose (Transform3D), every step
    world/robots/r0/body, .../heading  static: the robot's disc and heading
    world/robots/r0/scan               lidar returns in the robot's frame, every step
    world/trails/r0                    the true path so far
    world/merged                       Transform3D: the true start pose of the merged
                                       map's reference robot, every merge round
    world/merged/map                   the merged map in that robot's frame
    maps/r0                            static: robot 0's map frame, mirrored as ``world``
    maps/r0/grid                       robot 0's own grid in its map frame
    merge/<quantity>/r0-r1             per pair and merge round (PAIR_QUANTITIES)
    merge/agreement                    per merge round: the merged map against the truth
    merge/accepted_pairs               per merge round: estimates the merger accepted
    merge/log                          one line per merge round
    team/coverage                      every step
    team/robot_coverage/r0             robot 0's own grid's coverage, every step
    team/path_length/r0, .../total     metres travelled by robot 0 and the team, every step
    team/overlap_rate                  sum of the robots' coverages over the team's, less one
    team/...                           any other scalar series of the team's exploration
                                       (TEAM: the viewer's "Team" chart shows them all but
                                       the path lengths, which have a chart of their own)

Quantities come first and pairs last in ``merge/``, so that one entity filter
(``merge/rotation_error_deg/**``) selects a quantity of every pair: rerun's
filters know a trailing ``/**`` but no ``*`` inside a path.

Time is the ``step`` sequence timeline (one tick per simulation step) and the
``sim_time`` duration timeline (simulated seconds).
"""

from __future__ import annotations

from tomosim.team.merger import robot_name

APPLICATION_ID = "tomosim"
"""Application id of every tomosim recording."""
STEP_TIMELINE = "step"
"""Sequence timeline: simulation steps."""
SIM_TIME_TIMELINE = "sim_time"
"""Duration timeline: simulated seconds."""

CONFIG = "run/config"
STATUS = "run/status"
WORLD = "world"
TRUTH = "world/truth"
WALLS = "world/walls"
MERGED_FRAME = "world/merged"
MERGED = "world/merged/map"
MAPS = "maps"
MERGE = "merge"
AGREEMENT = "merge/agreement"
ACCEPTED_PAIRS = "merge/accepted_pairs"
MERGE_LOG = "merge/log"
TEAM = "team"
COVERAGE = "team/coverage"
OVERLAP_RATE = "team/overlap_rate"
PATH_LENGTHS = "team/path_length"
PATH_LENGTH_TOTAL = "team/path_length/total"

PAIR_QUANTITIES = (
    "confidence",
    "accepted",
    "confirmed",
    "used",
    "dropped",
    "matching_index",
    "rotation_error_deg",
    "translation_error_m",
    "shared_free_m2",
)
"""Logged per pair and round; the two errors only for estimates the merger accepted.
``used`` (1.0) marks an estimate the round's linking took as an edge of its forest,
``dropped`` a confirmed one it left out because it contradicts the others."""
ERROR_QUANTITIES = ("rotation_error_deg", "translation_error_m")
"""The quantities logged only for accepted estimates."""

STATUS_RUNNING = "running"
"""First word of ``run/status`` while the run goes on."""
STATUS_FINISHED = "finished"
"""First word of ``run/status`` after a run that ended by itself."""

ROBOT_COLOURS = (
    (31, 119, 180),
    (255, 127, 14),
    (44, 160, 44),
    (214, 39, 40),
    (148, 103, 189),
    (140, 86, 75),
    (227, 119, 194),
    (23, 190, 207),
)
"""RGB colour of robot ``k`` is ``ROBOT_COLOURS[k % len(ROBOT_COLOURS)]``."""


PAIR_COLOURS = (
    (27, 158, 119),
    (217, 95, 2),
    (117, 112, 179),
    (231, 41, 138),
    (102, 166, 30),
    (230, 171, 2),
    (166, 118, 29),
    (102, 102, 102),
)
"""RGB of a pair's series in the charts, the same in every chart: the pairs in the
order r0-r1, r0-r2, r1-r2, r0-r3, ... take the colours in turn (any team size)."""


def pair_colour(first: int, second: int) -> tuple[int, int, int]:
    """The RGB colour of the series of the pair of robots ``first < second``."""
    if not 0 <= first < second:
        raise ValueError(f"a pair needs robots 0 <= first < second, got ({first}, {second})")
    index = second * (second - 1) // 2 + first
    return PAIR_COLOURS[index % len(PAIR_COLOURS)]


def robot_colour(robot: int) -> tuple[int, int, int]:
    """The RGB colour robot ``robot`` is drawn in."""
    return ROBOT_COLOURS[robot % len(ROBOT_COLOURS)]


def robot_path(robot: int) -> str:
    """``world/robots/r0``: the robot's true pose."""
    return f"world/robots/{robot_name(robot)}"


def trail_path(robot: int) -> str:
    """``world/trails/r0``: the robot's true path."""
    return f"world/trails/{robot_name(robot)}"


def map_frame_path(robot: int) -> str:
    """``maps/r0``: the robot's map frame (mirrored for the 2-D views)."""
    return f"{MAPS}/{robot_name(robot)}"


def map_path(robot: int) -> str:
    """``maps/r0/grid``: the robot's own grid."""
    return f"{map_frame_path(robot)}/grid"


def quantity_path(quantity: str) -> str:
    """``merge/rotation_error_deg``: the subtree of one quantity, a series per pair below it."""
    if quantity not in PAIR_QUANTITIES:
        raise ValueError(f"unknown pair quantity {quantity!r}; choose one of {PAIR_QUANTITIES}")
    return f"{MERGE}/{quantity}"


def robot_coverage_path(robot: int) -> str:
    """``team/robot_coverage/r0``: the coverage of the robot's own grid."""
    return f"team/robot_coverage/{robot_name(robot)}"


def path_length_path(robot: int) -> str:
    """``team/path_length/r0``: metres the robot travelled."""
    return f"{PATH_LENGTHS}/{robot_name(robot)}"


def pair_path(pair: str, quantity: str) -> str:
    """``merge/rotation_error_deg/r0-r1``: one quantity of one pair."""
    return f"{quantity_path(quantity)}/{pair}"
