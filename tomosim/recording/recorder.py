"""Logging a team's exploration to a rerun recording.

The algorithms return data; the :class:`Recorder` takes an explicit
``rerun.RecordingStream`` and logs that data under the entity tree of
:mod:`tomosim.recording.paths`:

* once, static: the run's settings, the ground truth, the walls, the robots'
  bodies, and where each robot's map frame lies in the world;
* every step: the true poses, the scans, the team coverage, and the tracked
  figures of :mod:`tomosim.episode.tracking` (each robot's coverage and path
  length, the team's path length and overlap rate; :meth:`Recorder.log_figures`);
* each robot's map when it has changed, at most every ``map_interval`` steps
  (and at the last step);
* every merge round: per pair the confidence, acceptance, confirmation and
  matching index, the errors of accepted estimates, the merged map and its
  agreement with the truth.

Grids are logged as ``GridMap`` images in the ROS coding (-1 shown as 255,
rviz's map colours) with row 0 at the top of the image, as images are, so the
grid's row 0 (its lowest ``y``) is flipped to the bottom. Robot and merged
maps are cut to the box of their known cells first (the rest is unknown
padding).
"""

from __future__ import annotations

import json
import math
import uuid
from collections.abc import Mapping
from pathlib import Path
from types import TracebackType
from typing import Any

import numpy as np
import rerun as rr
from numpy.typing import NDArray

from merging.grid import OccupancyGrid
from tomosim.episode.tracking import StepFigures
from tomosim.recording.blueprint import default_blueprint
from tomosim.recording.paths import (
    ACCEPTED,
    AGREEMENT,
    APPLICATION_ID,
    CONFIG,
    COVERAGE,
    ERROR_QUANTITIES,
    MERGE_LOG,
    MERGED,
    OVERLAP_RATE,
    PATH_LENGTH_TOTAL,
    SIM_TIME_TIMELINE,
    STEP_TIMELINE,
    TRUTH,
    WALLS,
    map_path,
    pair_path,
    path_length_path,
    robot_colour,
    robot_coverage_path,
    robot_path,
    trail_path,
)
from tomosim.team.quality import RoundQuality
from tomosim.team.session import TeamSession
from tomosim.team.sharing import known_box

MAP_INTERVAL = 10
"""Least number of steps between two logs of one robot's map (a second of
simulated time): maps change nearly every step, images are large."""
MERGED_OPACITY = 0.7
"""Opacity of the merged map over the truth in the world view."""
DRAW_ORDER = {"truth": 0.0, "map": 1.0, "merged": 2.0}
"""Layering of the grid maps that overlap in the world view (higher on top)."""
WALL_COLOUR = (60, 60, 60)
"""RGB of the wall segments."""
SCAN_RADIUS = 0.03
"""Metres: radius of a drawn lidar return."""


def crop_to_known(grid: OccupancyGrid) -> OccupancyGrid:
    """The smallest part of ``grid`` holding all its known cells, in place (origin moved)."""
    box = known_box(grid.data)
    if box is None:
        return grid
    rows, cols = box
    ox, oy, yaw = grid.origin
    c, s = math.cos(yaw), math.sin(yaw)
    dx, dy = cols.start * grid.resolution, rows.start * grid.resolution
    origin = (ox + c * dx - s * dy, oy + s * dx + c * dy, yaw)
    return OccupancyGrid(grid.data[rows, cols], resolution=grid.resolution, origin=origin)


def grid_map(grid: OccupancyGrid, *, draw_order: float, opacity: float = 1.0) -> rr.GridMap:
    """``grid`` as a rerun ``GridMap`` in its own frame (module docstring)."""
    rows, cols = grid.shape
    ox, oy, yaw = grid.origin
    return rr.GridMap(
        data=np.ascontiguousarray(grid.data[::-1]).view(np.uint8).tobytes(),
        format=rr.components.ImageFormat(
            width=cols, height=rows, color_model="L", channel_datatype="U8"
        ),
        cell_size=grid.resolution,
        translation=[ox, oy, 0.0],
        rotation_axis_angle=rr.RotationAxisAngle(axis=[0.0, 0.0, 1.0], radians=yaw),
        colormap=rr.components.Colormap.RvizMap,
        draw_order=draw_order,
        opacity=opacity,
    )


def pose_transform(pose: NDArray[np.float64]) -> rr.Transform3D:
    """A planar pose ``(x, y, theta)`` as a rerun transform (rotation about ``z``)."""
    x, y, theta = (float(v) for v in pose)
    return rr.Transform3D(
        translation=[x, y, 0.0],
        rotation_axis_angle=rr.RotationAxisAngle(axis=[0.0, 0.0, 1.0], radians=theta),
    )


class Recorder:
    """Logs a :class:`~tomosim.team.TeamSession` to ``stream`` (module docstring).

    Parameters
    ----------
    stream : rerun.RecordingStream
        Where to log; the recorder never touches the global recording.
    map_interval : int
        Least number of steps between two logs of one robot's map.
    """

    __slots__ = ("_closed", "_last_maps", "_logged_at", "_trails", "map_interval", "stream")

    def __init__(self, stream: rr.RecordingStream, *, map_interval: int = MAP_INTERVAL) -> None:
        if not isinstance(stream, rr.RecordingStream):
            raise TypeError(f"stream must be a rerun.RecordingStream, got {type(stream).__name__}")
        if map_interval < 1:
            raise ValueError(f"map_interval must be at least 1 step, got {map_interval}")
        self.stream = stream
        self.map_interval = int(map_interval)
        self._last_maps: dict[int, OccupancyGrid] = {}
        self._logged_at: dict[int, int] = {}
        self._trails: dict[int, list[tuple[float, float, float]]] = {}
        self._closed = False

    @classmethod
    def to_file(
        cls,
        path: str | Path,
        *,
        robots: int,
        bounds: tuple[float, float, float, float],
        map_interval: int = MAP_INTERVAL,
    ) -> Recorder:
        """A recorder writing a new ``.rrd`` file with the default blueprint inside.

        Parameters
        ----------
        path : str or Path
            The file; its folder must exist.
        robots : int
            Number of robots (for the blueprint's tabs).
        bounds : (xmin, ymin, xmax, ymax)
            The world's extent in metres (for the blueprint's initial eye).
        """
        stream = rr.RecordingStream(APPLICATION_ID, recording_id=uuid.uuid4())
        stream.set_log_time_enabled(False)
        stream.save(Path(path), default_blueprint=default_blueprint(robots, bounds))
        return cls(stream, map_interval=map_interval)

    def __enter__(self) -> Recorder:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.close()

    def close(self) -> None:
        """Flush everything logged and finish the file (safe to call twice)."""
        if self._closed:
            return
        self._closed = True
        self.stream.flush()
        self.stream.disconnect()

    def _set_time(self, session: TeamSession) -> None:
        self.stream.set_time(STEP_TIMELINE, sequence=session.steps)
        self.stream.set_time(SIM_TIME_TIMELINE, duration=session.simulation.time)

    def log_start(self, session: TeamSession, settings: Mapping[str, Any]) -> None:
        """The static part (settings, world, robot bodies, map frames) and step 0."""
        log = self.stream.log
        log(CONFIG, rr.TextDocument(json.dumps(dict(settings), indent=2)), static=True)
        log("/", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        world = session.world
        log(TRUTH, grid_map(world.truth, draw_order=DRAW_ORDER["truth"]), static=True)
        segments = np.concatenate([world.walls, np.zeros((*world.walls.shape[:2], 1))], axis=2)
        log(WALLS, rr.LineStrips3D(segments, colors=[WALL_COLOUR]), static=True)
        radius = session.config.simulation.physics.robot_radius
        for k, start in enumerate(session.simulation.start_poses):
            colour = robot_colour(k)
            body = rr.Points3D([[0.0, 0.0, 0.0]], radii=radius, colors=[colour])
            log(f"{robot_path(k)}/body", body, static=True)
            heading = rr.Arrows3D(
                origins=[[0.0, 0.0, 0.0]], vectors=[[2 * radius, 0.0, 0.0]], colors=[colour]
            )
            log(f"{robot_path(k)}/heading", heading, static=True)
            log(map_path(k), pose_transform(start), static=True)
        self.log_step(session, None)

    def log_step(self, session: TeamSession, merge: RoundQuality | None) -> None:
        """One step: poses, scans, coverage, changed maps and the merge round, if any."""
        self._set_time(session)
        log = self.stream.log
        poses = session.simulation.true_poses
        for k, (pose, scan) in enumerate(zip(poses, session.simulation.scans, strict=True)):
            log(robot_path(k), pose_transform(pose))
            hits = scan.points((0.0, 0.0, 0.0))
            points = np.column_stack([hits, np.zeros(len(hits))])
            log(
                f"{robot_path(k)}/scan",
                rr.Points3D(points, radii=SCAN_RADIUS, colors=[robot_colour(k)]),
            )
            self._trails.setdefault(k, []).append((float(pose[0]), float(pose[1]), 0.0))
        log(COVERAGE, rr.Scalars(session.coverage.fraction))
        self._log_maps(session, force=False)
        if merge is not None:
            self.log_merge(session, merge)

    def log_figures(self, session: TeamSession, figures: StepFigures) -> None:
        """The tracked figures of the current step, as scalars under ``team/``."""
        self._set_time(session)
        log = self.stream.log
        for k, (covered, travelled) in enumerate(
            zip(figures.robot_coverage, figures.path_lengths, strict=True)
        ):
            log(robot_coverage_path(k), rr.Scalars(covered))
            log(path_length_path(k), rr.Scalars(travelled))
        log(PATH_LENGTH_TOTAL, rr.Scalars(figures.path_length))
        log(OVERLAP_RATE, rr.Scalars(figures.overlap_rate))

    def _log_maps(self, session: TeamSession, *, force: bool) -> None:
        """Each robot's grid if it changed and ``map_interval`` steps passed (or ``force``)."""
        step = session.steps
        for k, grid in enumerate(session.grids()):
            last = self._logged_at.get(k)
            if not force and last is not None and step - last < self.map_interval:
                continue
            previous = self._last_maps.get(k)
            if (
                previous is not None
                and previous.origin == grid.origin
                and np.array_equal(previous.data, grid.data)
            ):
                continue
            shown = grid_map(crop_to_known(grid), draw_order=DRAW_ORDER["map"])
            self.stream.log(map_path(k), shown)
            self._last_maps[k] = grid
            self._logged_at[k] = step
            self.stream.log(
                trail_path(k),
                rr.LineStrips3D([self._trails.get(k, [])], colors=[robot_colour(k)]),
            )

    def log_merge(self, session: TeamSession, merge: RoundQuality) -> None:
        """One merge round's quality figures and merged map, at the current time."""
        log = self.stream.log
        for pair in merge.pairs:
            values = {
                "confidence": pair.confidence,
                "accepted": float(pair.accepted),
                "confirmed": float(pair.confirmed),
                "matching_index": pair.matching_index,
                "rotation_error_deg": pair.rotation_error_deg,
                "translation_error_m": pair.translation_error_m,
            }
            for quantity, value in values.items():
                if quantity in ERROR_QUANTITIES and not pair.accepted:
                    continue
                log(pair_path(pair.name, quantity), rr.Scalars(value))
        log(AGREEMENT, rr.Scalars(merge.agreement))
        log(ACCEPTED, rr.Scalars(float(len(merge.accepted))))
        start = session.simulation.start_poses[merge.merge.reference]
        log(MERGED, pose_transform(start))
        merged = grid_map(
            crop_to_known(merge.merge.merged),
            draw_order=DRAW_ORDER["merged"],
            opacity=MERGED_OPACITY,
        )
        log(MERGED, merged)
        log(MERGE_LOG, rr.TextLog(merge_line(merge), level="INFO"))

    def log_end(self, session: TeamSession) -> None:
        """The last step's maps, whatever the interval, so the recording ends complete."""
        self._set_time(session)
        self._log_maps(session, force=True)


def merge_line(merge: RoundQuality) -> str:
    """One line describing a merge round (for the recording's text log)."""
    parts = []
    for pair in merge.pairs:
        state = "confirmed" if pair.confirmed else "accepted" if pair.accepted else "rejected"
        text = f"{pair.name} {state} ({pair.confidence:.2f}"
        if pair.accepted and math.isfinite(pair.rotation_error_deg):
            text += f", {pair.rotation_error_deg:.2f} deg, {pair.translation_error_m:.3f} m"
        parts.append(text + ")")
    robots = ", ".join(f"r{k}" for k in merge.merged_robots)
    return f"step {merge.step}: " + "; ".join(parts) + f"; merged map of {robots}"
