"""Logging a team's exploration to a rerun recording.

The algorithms return data; the :class:`Recorder` takes an explicit
``rerun.RecordingStream`` and logs that data under the entity tree of
:mod:`tomosim.recording.paths`:

* once, at the start: the default blueprint (:mod:`tomosim.recording.blueprint`),
  the run's settings, ``run/status`` "running", the ground truth, the walls,
  the robots' bodies and the colours of the maps (:mod:`tomosim.recording.colours`);
* every step: the true poses, the scans, the team coverage, and the tracked
  figures of :mod:`tomosim.episode.exploration_tracker` (each robot's coverage and path
  length, the team's path length and overlap rate; :meth:`Recorder.log_figures`);
* each robot's map when it has changed, at most every ``map_interval`` steps
  (and at the last step);
* every merge round: per pair the confidence, acceptance, confirmation and
  matching index, the errors of accepted estimates, the merged map and its
  agreement with the truth;
* at the end, ``run/status``: how the run ended.

Grids are logged as ``SegmentationImage`` of their ROS cell values with a
``Transform3D`` that scales image pixels to cells of ``resolution`` metres
and places the grid's origin, so image row 0 is the grid's row 0 (its lowest
``y``). Robot and merged maps are cut to the box of their known cells first
(the rest is unknown padding). Everything is drawn in 2-D: the ``world`` and
``maps/rK`` frames mirror ``y`` once, because rerun's 2-D views draw ``y``
down.

Writing is checked every ``FLUSH_INTERVAL_S`` seconds: a recording that
cannot be written (a full disk, a file removed) raises :class:`RecordingError`
during the run, not after it.
"""

from __future__ import annotations

import json
import math
import sys
import time
from collections.abc import Mapping
from pathlib import Path
from types import TracebackType
from typing import Any

import numpy as np
import rerun as rr
from numpy.typing import NDArray

from merging.grid import OccupancyGrid
from tomosim.episode.exploration_tracker import StepFigures
from tomosim.recording.blueprint import default_blueprint
from tomosim.recording.colours import map_classes, merged_classes
from tomosim.recording.paths import (
    ACCEPTED_PAIRS,
    AGREEMENT,
    CONFIG,
    COVERAGE,
    ERROR_QUANTITIES,
    MAPS,
    MERGE_LOG,
    MERGED,
    MERGED_FRAME,
    OVERLAP_RATE,
    PATH_LENGTH_TOTAL,
    SIM_TIME_TIMELINE,
    STATUS,
    STATUS_FINISHED,
    STATUS_RUNNING,
    STEP_TIMELINE,
    TRUTH,
    WALLS,
    WORLD,
    map_frame_path,
    map_path,
    pair_colour,
    pair_path,
    path_length_path,
    robot_colour,
    robot_coverage_path,
    robot_path,
    trail_path,
)
from tomosim.recording.sinks import LiveViewer, RecordingError, Sinks, unwritable
from tomosim.team.merger import robot_name
from tomosim.team.quality import RoundQuality
from tomosim.team.session import TeamSession
from tomosim.team.sharing import known_box

MAP_INTERVAL = 10
"""Least number of steps between two logs of one robot's map (a second of
simulated time): maps change nearly every step, images are large."""
FLUSH_INTERVAL_S = 2.0
"""Wall-clock seconds between two checks that the recording is being written;
also the most a killed run loses."""
FLUSH_TIMEOUT_S = 10.0
"""Longest wait, in seconds, for logged data to reach the file and viewers."""
DRAW_ORDER = {
    "truth": 0.0,
    "walls": 1.0,
    "map": 1.0,
    "merged": 2.0,
    "trail": 3.0,
    "scan": 4.0,
    "body": 5.0,
    "heading": 6.0,
}
"""Layering in the 2-D views (higher on top)."""
WALL_COLOUR = (60, 60, 60)
"""RGB of the wall segments."""
WALL_WIDTH = rr.Radius.ui_points(0.5)
"""Wall segments, a thin line at any zoom (UI points)."""
TRAIL_WIDTH = rr.Radius.ui_points(1.0)
"""A robot's path (UI points)."""
SCAN_RADIUS = rr.Radius.ui_points(1.5)
"""A drawn lidar return (UI points)."""
BODY_RADIUS = rr.Radius.ui_points(5.0)
"""A robot's disc, drawn the same size at any zoom (UI points): a robot is some
0.2 m, a handful of pixels when the whole floor is in view."""
AGREEMENT_COLOUR = (235, 235, 235)
"""RGB of the merged map's agreement series: near white on the charts' dark
background, apart from the pairs' colours."""
TEAM_COLOUR = (235, 235, 235)
"""RGB of the team's coverage and total path length (each robot's is in its colour)."""
OVERLAP_COLOUR = (255, 215, 0)
"""RGB of the overlap rate: a yellow no robot or pair is drawn in."""
HEADING_RADII = 3.0
"""Length of the heading arrow in robot radii."""
MIRROR_Y = rr.Transform3D(scale=[1.0, -1.0, 1.0])
"""The mirror of the ``world`` and ``maps/rK`` frames (module docstring)."""


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


def grid_placement(grid: OccupancyGrid) -> rr.Transform3D:
    """Image pixels of ``grid`` to its frame: scaled by the resolution, placed at its origin."""
    ox, oy, yaw = grid.origin
    return rr.Transform3D(
        translation=[ox, oy, 0.0],
        rotation_axis_angle=rr.RotationAxisAngle(axis=[0.0, 0.0, 1.0], radians=yaw),
        scale=[grid.resolution, grid.resolution, 1.0],
    )


def grid_image(grid: OccupancyGrid, *, draw_order: float) -> rr.SegmentationImage:
    """``grid``'s ROS cell values as class ids (-1 as 255), row 0 first (module docstring)."""
    return rr.SegmentationImage(
        np.ascontiguousarray(grid.data).view(np.uint8), opacity=1.0, draw_order=draw_order
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
    path : Path, optional
        The file the stream writes to, for messages.
    """

    __slots__ = (
        "_attached",
        "_closed",
        "_flushed_at",
        "_last_maps",
        "_logged_at",
        "_sinks",
        "_status",
        "_step",
        "_styled",
        "_trails",
        "map_interval",
        "path",
        "stream",
        "viewer_error",
        "watch",
    )

    def __init__(
        self,
        stream: rr.RecordingStream,
        *,
        map_interval: int = MAP_INTERVAL,
        path: Path | None = None,
    ) -> None:
        if not isinstance(stream, rr.RecordingStream):
            raise TypeError(f"stream must be a rerun.RecordingStream, got {type(stream).__name__}")
        if map_interval < 1:
            raise ValueError(f"map_interval must be at least 1 step, got {map_interval}")
        self.stream = stream
        self.map_interval = int(map_interval)
        self.path = path
        self.viewer_error: str | None = None
        self.watch: str | None = None
        self._last_maps: dict[int, OccupancyGrid] = {}
        self._logged_at: dict[int, int] = {}
        self._trails: dict[int, list[tuple[float, float]]] = {}
        self._closed = False
        self._attached = False
        self._status: str | None = None
        self._styled: set[str] = set()
        self._sinks: Sinks | None = None
        self._step = 0
        self._flushed_at = time.monotonic()

    @classmethod
    def to_file(cls, path: str | Path, *, map_interval: int = MAP_INTERVAL) -> Recorder:
        """A recorder writing a new ``.rrd`` file (its folder must exist).

        Raises
        ------
        RecordingError
            If the file cannot be created.
        """
        return cls.open(record=Path(path), map_interval=map_interval)

    @classmethod
    def open(
        cls,
        *,
        record: Path | None = None,
        live: LiveViewer | None = None,
        map_interval: int = MAP_INTERVAL,
    ) -> Recorder:
        """A recorder writing ``record`` and showing on ``live`` (:class:`Sinks`).

        The file is created, or emptied, only when :meth:`log_start` logs the
        run's first data, so a run that fails before it starts leaves an
        existing file of that name as it was.
        """
        sinks = Sinks(record, live)
        recorder = cls(sinks.stream, map_interval=map_interval, path=record)
        recorder.watch = sinks.watch
        recorder._sinks = sinks
        return recorder

    def __enter__(self) -> Recorder:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.close()

    @property
    def status(self) -> str | None:
        """The last ``run/status`` logged (None before :meth:`log_start`)."""
        return self._status

    def _flush(self, *, final: bool = False) -> None:
        """Push logged data out; :class:`RecordingError` if the file cannot be written.

        A viewer that went away is not an error: :attr:`viewer_error` says so
        and the file goes on being written.
        """
        try:
            self.stream.flush(timeout_sec=FLUSH_TIMEOUT_S)
        except RuntimeError as exc:  # rerun reports every sink's failure this way
            message = " ".join(str(exc).split())
            if "grpc" in message.lower() and "file" not in message.lower():
                self.viewer_error = message
                return
            if not final:
                self._closed = True
                self.stream.disconnect()
            if self.path is None:
                raise RecordingError(f"cannot show the run live: {message}") from exc
            raise unwritable(self.path, message) from exc
        self._flushed_at = time.monotonic()

    def close(self) -> None:
        """Flush everything logged and finish the file (safe to call twice).

        A run that never logged how it ended is marked as stopped at its last step.

        Raises
        ------
        RecordingError
            If what was logged could not be written.
        """
        if self._closed:
            return
        # An exception propagating through the caller's ``finally`` (a failed or
        # interrupted run) is what the caller must see, not a failed flush after it.
        propagating = sys.exc_info()[1]
        if self._status is not None and self._status.startswith(STATUS_RUNNING):
            self.log_status(f"stopped at step {self._step} before its end")
        self._closed = True
        if self._sinks is not None and self._status is None:  # never started: nothing to write
            self.stream.disconnect()
            return
        try:
            self._flush(final=True)
        except RecordingError:
            if propagating is None:
                raise
        finally:
            self.stream.disconnect()

    def log_status(self, status: str) -> None:
        """Set ``run/status`` (first word: running, finished, interrupted, stopped, ...)."""
        self._status = status
        self.stream.log(STATUS, rr.TextDocument(status), static=True)

    def _set_time(self, session: TeamSession) -> None:
        self._step = session.steps
        self.stream.set_time(STEP_TIMELINE, sequence=session.steps)
        self.stream.set_time(SIM_TIME_TIMELINE, duration=session.simulation.time)

    def log_start(self, session: TeamSession, settings: Mapping[str, Any]) -> None:
        """The blueprint, the static part (settings, world, robot bodies, colours) and step 0.

        Raises
        ------
        RecordingError
            If the file cannot be created or a viewer's port is taken.
        """
        self._attached = True  # from here on the file is created (or emptied)
        if self._sinks is not None:
            self._sinks.attach()
        world = session.world
        merging = bool(session.config.merge)
        self.stream.send_blueprint(
            default_blueprint(session.count, world.bounds, merging=merging),
            make_active=True,
            make_default=True,
        )
        log = self.stream.log
        log(CONFIG, rr.TextDocument(json.dumps(dict(settings), indent=2)), static=True)
        self.log_status(STATUS_RUNNING)
        log(WORLD, MIRROR_Y, map_classes(), static=True)
        log(MAPS, map_classes(), static=True)
        log(MERGED_FRAME, merged_classes(), static=True)
        log(TRUTH, grid_placement(world.truth), static=True)
        log(TRUTH, grid_image(world.truth, draw_order=DRAW_ORDER["truth"]), static=True)
        walls = rr.LineStrips2D(
            list(world.walls),
            radii=WALL_WIDTH,
            colors=[WALL_COLOUR],
            draw_order=DRAW_ORDER["walls"],
        )
        log(WALLS, walls, static=True)
        radius = session.config.simulation.physics.robot_radius
        for k in range(session.count):
            colour = robot_colour(k)
            body = rr.Points2D(
                [[0.0, 0.0]],
                radii=BODY_RADIUS,
                colors=[colour],
                labels=[robot_name(k)],
                draw_order=DRAW_ORDER["body"],
            )
            log(f"{robot_path(k)}/body", body, static=True)
            heading = rr.Arrows2D(
                origins=[[0.0, 0.0]],
                vectors=[[HEADING_RADII * radius, 0.0]],
                colors=[(0, 0, 0)],
                draw_order=DRAW_ORDER["heading"],
            )
            log(f"{robot_path(k)}/heading", heading, static=True)
            log(map_frame_path(k), MIRROR_Y, static=True)
        self._style_team_series(session.count)
        self.log_step(session, None)

    def _style_team_series(self, robots: int) -> None:
        """Name the team's series and colour each robot's as the robot is drawn: unstyled,
        the viewer picks colours of its own, and a robot's path length and the team's
        total may share one."""
        styles = {
            COVERAGE: ("team coverage", TEAM_COLOUR),
            OVERLAP_RATE: ("overlap rate", OVERLAP_COLOUR),
            PATH_LENGTH_TOTAL: ("team total", TEAM_COLOUR),
        }
        for k in range(robots):
            styles[robot_coverage_path(k)] = (f"{robot_name(k)} own map", robot_colour(k))
            styles[path_length_path(k)] = (robot_name(k), robot_colour(k))
        for path, (name, colour) in styles.items():
            self.stream.log(path, rr.SeriesLines(colors=[colour], names=[name]), static=True)

    def log_step(self, session: TeamSession, merge: RoundQuality | None) -> None:
        """One step: poses, scans, coverage, changed maps and the merge round, if any."""
        self._set_time(session)
        log = self.stream.log
        poses = session.simulation.true_poses
        for k, (pose, scan) in enumerate(zip(poses, session.simulation.scans, strict=True)):
            log(robot_path(k), pose_transform(pose))
            hits = scan.points((0.0, 0.0, 0.0))
            log(
                f"{robot_path(k)}/scan",
                rr.Points2D(
                    hits,
                    radii=SCAN_RADIUS,
                    colors=[robot_colour(k)],
                    draw_order=DRAW_ORDER["scan"],
                ),
            )
            self._trails.setdefault(k, []).append((float(pose[0]), float(pose[1])))
        log(COVERAGE, rr.Scalars(session.coverage.fraction))
        self._log_maps(session, force=False)
        if merge is not None:
            self.log_merge(session, merge)
        if time.monotonic() - self._flushed_at >= FLUSH_INTERVAL_S:
            self._flush()

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
            shown = crop_to_known(grid)
            self.stream.log(
                map_path(k),
                grid_placement(shown),
                grid_image(shown, draw_order=DRAW_ORDER["map"]),
            )
            self._last_maps[k] = grid
            self._logged_at[k] = step
            trail = rr.LineStrips2D(
                [self._trails.get(k, [])],
                radii=TRAIL_WIDTH,
                colors=[robot_colour(k)],
                draw_order=DRAW_ORDER["trail"],
            )
            self.stream.log(trail_path(k), trail)

    def log_merge(self, session: TeamSession, merge: RoundQuality) -> None:
        """One merge round's quality figures and merged map, at the current time."""
        log = self.stream.log
        for pair in merge.pairs:
            colour = pair_colour(pair.first, pair.second)
            values = {
                "confidence": pair.confidence,
                "accepted": float(pair.accepted),
                "confirmed": float(pair.confirmed),
                "used": float(pair.used),
                "dropped": float(pair.dropped),
                "matching_index": pair.matching_index,
                "rotation_error_deg": pair.rotation_error_deg,
                "translation_error_m": pair.translation_error_m,
                "shared_free_m2": pair.shared_free_m2,
            }
            for quantity, value in values.items():
                if quantity in ERROR_QUANTITIES and not pair.accepted:
                    continue
                path = pair_path(pair.name, quantity)
                if path not in self._styled:
                    self._styled.add(path)
                    style = rr.SeriesLines(colors=[colour], names=[pair.name])
                    log(path, style, static=True)
                log(path, rr.Scalars(value))
        if AGREEMENT not in self._styled:
            self._styled.add(AGREEMENT)
            style = rr.SeriesLines(colors=[AGREEMENT_COLOUR], names=["merged-map agreement"])
            log(AGREEMENT, style, static=True)
        log(AGREEMENT, rr.Scalars(merge.agreement))
        log(ACCEPTED_PAIRS, rr.Scalars(float(len(merge.accepted))))
        start = session.simulation.start_poses[merge.merge.reference]
        log(MERGED_FRAME, pose_transform(start))
        merged = crop_to_known(merge.merge.merged)
        log(MERGED, grid_placement(merged), grid_image(merged, draw_order=DRAW_ORDER["merged"]))
        log(MERGE_LOG, rr.TextLog(merge_line(merge), level="INFO"))

    def log_end(self, session: TeamSession, reason: str | None = None) -> None:
        """The last step's maps, whatever the interval, and ``run/status`` "finished".

        Parameters
        ----------
        reason : str, optional
            Why the run ended (recorded in the status).
        """
        self._set_time(session)
        self._log_maps(session, force=True)
        ended = f"{STATUS_FINISHED} at step {session.steps}"
        self.log_status(f"{ended}: {reason}" if reason else ended)

    @property
    def started(self) -> bool:
        """Whether :meth:`log_start` has begun (before it, no file is created or emptied)."""
        return self._attached

    @property
    def last_step(self) -> int:
        """The step of the latest state logged (what the recording keeps the run up to)."""
        return self._step

    def log_interrupted(self, why: str) -> None:
        """``run/status`` "interrupted at step N: why" (the run was stopped from outside)."""
        self.log_status(f"interrupted at step {self._step}: {why}")


def merge_line(merge: RoundQuality) -> str:
    """One line describing a merge round (for the recording's text log)."""
    parts = []
    for pair in merge.pairs:
        state = "confirmed" if pair.confirmed else "accepted" if pair.accepted else "rejected"
        if pair.used or pair.dropped:
            state += ", used" if pair.used else ", dropped"
        text = f"{pair.name} {state} ({pair.confidence:.2f}"
        if pair.accepted and math.isfinite(pair.rotation_error_deg):
            text += f", {pair.rotation_error_deg:.2f} deg, {pair.translation_error_m:.3f} m"
        parts.append(text + ")")
    robots = ", ".join(f"r{k}" for k in merge.merged_robots)
    return f"step {merge.step}: " + "; ".join(parts) + f"; merged map of {robots}"


__all__ = [
    "Recorder",
    "RecordingError",
    "crop_to_known",
    "grid_image",
    "grid_placement",
    "merge_line",
    "pose_transform",
]
