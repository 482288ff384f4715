"""The entity tree of a tomosim recording, and its timelines.

::

    run/config                         static: the run's settings (JSON text)
    world/truth                        static: ground-truth grid (GridMap)
    world/walls                        static: wall segments
    world/robots/r0                    true pose (Transform3D), every step
    world/robots/r0/body, .../heading  static: the robot's disc and heading
    world/robots/r0/scan               lidar returns in the robot's frame, every step
    world/trails/r0                    true path so far
    maps/r0                            robot 0's own grid in its map frame (GridMap);
                                       static Transform3D: its true start pose
    maps/merged                        the merged map, in its reference robot's frame;
                                       Transform3D: that robot's true start pose
    merge/r0-r1/<quantity>             per pair and merge round (PAIR_QUANTITIES)
    merge/agreement, merge/accepted    per merge round
    merge/log                          one line per merge round
    team/coverage                      every step
    team/robot_coverage/r0             robot 0's own grid's coverage, every step
    team/path_length/r0, .../total     metres travelled by robot 0 and the team, every step
    team/overlap_rate                  sum of the robots' coverages over the team's, less one

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
TRUTH = "world/truth"
WALLS = "world/walls"
MERGED = "maps/merged"
AGREEMENT = "merge/agreement"
ACCEPTED = "merge/accepted"
MERGE_LOG = "merge/log"
COVERAGE = "team/coverage"
OVERLAP_RATE = "team/overlap_rate"
PATH_LENGTH_TOTAL = "team/path_length/total"

PAIR_QUANTITIES = (
    "confidence",
    "accepted",
    "confirmed",
    "matching_index",
    "rotation_error_deg",
    "translation_error_m",
)
"""Logged per pair and round; the two errors only for estimates the merger accepted."""
ERROR_QUANTITIES = ("rotation_error_deg", "translation_error_m")
"""The quantities logged only for accepted estimates."""

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


def robot_colour(robot: int) -> tuple[int, int, int]:
    """The RGB colour robot ``robot`` is drawn in."""
    return ROBOT_COLOURS[robot % len(ROBOT_COLOURS)]


def robot_path(robot: int) -> str:
    """``world/robots/r0``: the robot's true pose."""
    return f"world/robots/{robot_name(robot)}"


def trail_path(robot: int) -> str:
    """``world/trails/r0``: the robot's true path."""
    return f"world/trails/{robot_name(robot)}"


def map_path(robot: int) -> str:
    """``maps/r0``: the robot's own grid."""
    return f"maps/{robot_name(robot)}"


def robot_coverage_path(robot: int) -> str:
    """``team/robot_coverage/r0``: the coverage of the robot's own grid."""
    return f"team/robot_coverage/{robot_name(robot)}"


def path_length_path(robot: int) -> str:
    """``team/path_length/r0``: metres the robot travelled."""
    return f"team/path_length/{robot_name(robot)}"


def pair_path(pair: str, quantity: str) -> str:
    """``merge/r0-r1/rotation_error_deg``: one quantity of one pair."""
    if quantity not in PAIR_QUANTITIES:
        raise ValueError(f"unknown pair quantity {quantity!r}; choose one of {PAIR_QUANTITIES}")
    return f"merge/{pair}/{quantity}"
