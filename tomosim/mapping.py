"""Log-odds occupancy mapping: a growing grid per robot, in the robot's own frame.

Inverse sensor model (per scan, vectorised over all beams):

1. each beam is sampled every :data:`SAMPLE_STEP_CELLS` cell from the sensor
   to its end point (excluded); the cells sampled are *passed*;
2. a beam that returned marks the cell of its end point *hit*; a beam with no
   return within range (``inf``) only passes cells up to ``max_range``; a
   dropout (``nan``) does nothing;
3. every passed cell gets ``log_odds_miss`` once per scan, however many beams
   pass it, then every hit cell gets ``log_odds_hit`` added to its value from
   before the scan (a hit wins over a pass in the same scan), and values are
   clamped to ``[log_odds_min, log_odds_max]``.

Counting a cell once per scan keeps the cells near the robot, which many
beams cross, from being over-weighted. Cells never observed stay unknown.
Exported grids use the ROS coding of :mod:`merging.grid`:
``round(100 / (1 + exp(-l)))`` for observed cells, ``-1`` for the rest
(:func:`ros_codes`).

:func:`integrate_rays` and :func:`ros_codes` state the model in numpy; a
:class:`LogOddsMap` applies it with the compiled kernel
:func:`tomosim.kernels.logodds.integrate_scan` (through
:func:`~tomosim.kernels.logodds.update_grid`, which also finds the beams' end
points), which the tests check against them, and keeps its ROS-coded grid up
to date cell by cell.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from merging.grid import UNKNOWN, OccupancyGrid
from merging.validators import boolean, real_number
from tomosim.kernels.logodds import (
    GROW_SCRATCH,
    INTEGRATED,
    SATURATED,
    SCAN_NUMBER_BITS,
    code_thresholds,
    update_grid,
)
from tomosim.lidar import Scan

HIT_DEPTH_CELLS = 0.5
"""Cells beyond the measured range at which a return marks its cell: a surface
lying on a cell boundary (as every wall of a world made from a grid does)
then marks the cell behind it, not the free cell in front, and range noise
well under half a cell rarely changes that."""
SAMPLE_STEP_CELLS = 1.0
"""Cells between samples along a beam: one sample per cell crossed straight;
a diagonal crossing may skip a corner cell, which neighbouring beams fill."""

STAMP_DTYPE = np.uint8
"""Type of the kernel's per-cell stamps (a scan number and a flag,
:mod:`tomosim.kernels.logodds`): one byte keeps them, and the cells a scan reads, in
fewer cache lines; their scan numbers are cleared every 127 scans, when the numbers
start again."""
MAX_GRID_SIDE_CELLS = 20000
"""Most cells a side that an initial grid or one growth step may take (20000 x
20000 cells of log-odds alone take 1.6 GB); a building at 0.05 m is a few
thousand."""
CODE_THRESHOLDS = code_thresholds()
"""Log-odds at which the ROS code of a cell steps up
(:func:`~tomosim.kernels.logodds.code_thresholds`)."""


@dataclass(frozen=True)
class MappingConfig:
    """Occupancy-grid parameters.

    Attributes
    ----------
    resolution : float
        Cell edge, metres.
    log_odds_hit, log_odds_miss : float
        Log-odds added for a hit (> 0) and a pass (< 0). The defaults make one
        hit enough for *occupied* (>= 65 %) and four passes for *free* (<= 19 %).
    log_odds_min, log_odds_max : float
        Clamp, so that a cell can change its mind after a few scans.
    initial_extent : float
        Side of the square grid allocated at the start, metres, centred on the
        robot.
    growth_padding : float
        Metres added beyond what a scan needs whenever the grid must grow.
    carve_no_return : bool
        Whether a beam with no return marks cells free up to ``max_range``.
    """

    resolution: float = 0.05
    log_odds_hit: float = 0.85
    log_odds_miss: float = -0.4
    log_odds_min: float = -2.0
    log_odds_max: float = 3.5
    initial_extent: float = 20.0
    growth_padding: float = 8.0
    carve_no_return: bool = True

    def __post_init__(self) -> None:
        real_number(self.resolution, "resolution", low=0.0, low_open=True, unit="metres")
        for name in (
            "log_odds_hit",
            "log_odds_miss",
            "log_odds_min",
            "log_odds_max",
            "initial_extent",
            "growth_padding",
        ):
            real_number(getattr(self, name), name)
        boolean(self.carve_no_return, "carve_no_return")
        if not (self.log_odds_hit > 0 > self.log_odds_miss):
            raise ValueError(
                f"need log_odds_hit > 0 > log_odds_miss, got "
                f"{self.log_odds_hit} and {self.log_odds_miss}"
            )
        if not (self.log_odds_min < 0 < self.log_odds_max):
            raise ValueError(
                f"need log_odds_min < 0 < log_odds_max, got "
                f"{self.log_odds_min} and {self.log_odds_max}"
            )
        if not (self.initial_extent > 0 and self.growth_padding >= 0):
            raise ValueError(
                f"initial_extent must be > 0 and growth_padding >= 0 metres, got "
                f"{self.initial_extent} and {self.growth_padding}"
            )
        for name in ("initial_extent", "growth_padding"):
            cells = getattr(self, name) / self.resolution
            if cells > MAX_GRID_SIDE_CELLS:
                raise ValueError(
                    f"{name} of {getattr(self, name)} m is {cells:.0f} cells at "
                    f"{self.resolution} m a cell, more than a grid holds "
                    f"({MAX_GRID_SIDE_CELLS} a side); give it in metres, a few tens "
                    "(the grid grows as the robot sees more)"
                )


def _check_scan(scan: Scan) -> None:
    """Raise unless ``scan`` holds one finite angle per range and a finite range limit.

    The compiled kernel reads one angle per range; it checks each beam's angle
    and range itself (finite, within ``[0, max_range]`` or ``inf``/``nan``).
    """
    _check_layout(np.asarray(scan.angles), np.shape(scan.ranges), scan.max_range)


def _check_layout(angles: NDArray[np.float64], shape: tuple[int, ...], limit: object) -> None:
    """:func:`_check_scan` of a scan whose ranges have ``shape``."""
    if angles.ndim != 1 or angles.shape != shape:
        raise ValueError(
            f"a scan needs one angle per range, got angles of shape {angles.shape} and "
            f"ranges of shape {shape}"
        )
    if type(limit) is float and 0.0 < limit < math.inf:  # the usual case, checked at once
        return
    try:
        real_number(limit, "a scan's max_range", low=0.0, low_open=True, unit="metres")
    except ValueError as error:  # SettingTypeError stays a TypeError too
        raise type(error)(
            f"{error} (a beam without return is inf; the limit is where the map stops carving)"
        ) from None


def ray_cells(
    origin: tuple[float, float], ends: NDArray[np.float64], hit: NDArray[np.bool_], cols: int
) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """The cells a scan passes and hits (steps 1-2 of the module docstring).

    Parameters are those of :func:`integrate_rays`, and ``cols``, the grid's width.

    Returns
    -------
    passed : (S,) intp ndarray
        Flat index (``row * cols + col``) of the cell of every sample, beam by beam
        and from the sensor out; a cell appears once per sample that lies in it.
    hit : (H,) intp ndarray
        Flat index of the hit cell of every beam that returned, in beam order.
    """
    ox, oy = origin
    dx = ends[:, 0] - ox
    dy = ends[:, 1] - oy
    counts = np.ceil(np.hypot(dx, dy) / SAMPLE_STEP_CELLS).astype(np.intp)
    np.maximum(counts, 1, out=counts)
    total = int(counts.sum())
    # Sample j of beam i sits at origin + j / counts[i] * (end - origin), j < counts[i].
    first = np.cumsum(counts) - counts
    step = np.arange(total, dtype=np.float32)
    step -= np.repeat(first.astype(np.float32), counts)
    xs = np.repeat((dx / counts).astype(np.float32), counts)
    xs *= step
    xs += np.float32(ox + 0.5)
    ys = np.repeat((dy / counts).astype(np.float32), counts)
    ys *= step
    ys += np.float32(oy + 0.5)
    passed = ys.astype(np.intp)
    passed *= cols
    passed += xs.astype(np.intp)
    # Hit cells: the end point carried HIT_DEPTH_CELLS further along its beam.
    lengths = np.maximum(np.hypot(dx[hit], dy[hit]), np.finfo(float).tiny)
    depth = HIT_DEPTH_CELLS / lengths
    hits = np.floor(
        np.column_stack([ends[hit, 0] + dx[hit] * depth, ends[hit, 1] + dy[hit] * depth]) + 0.5
    ).astype(np.intp)
    return passed, hits[:, 1] * cols + hits[:, 0]


def integrate_rays(
    logodds: NDArray[np.float32],
    observed: NDArray[np.bool_],
    origin: tuple[float, float],
    ends: NDArray[np.float64],
    hit: NDArray[np.bool_],
    config: MappingConfig,
) -> None:
    """Apply one scan to a log-odds grid in place (steps 1-3 of the module docstring).

    Parameters
    ----------
    logodds : (rows, cols) float32 ndarray
        Log-odds per cell, indexed ``[row, col]``; updated in place.
    observed : (rows, cols) bool ndarray
        Set in place for every cell the scan touches.
    origin : (float, float)
        Sensor position in cell coordinates ``(x, y) = (col, row)``, cell
        centres at integers.
    ends : (M, 2) float ndarray
        Beam end points in cell coordinates; all of them, and ``origin``,
        must lie inside the grid.
    hit : (M,) bool ndarray
        Whether each beam's end point is an obstacle.
    config : MappingConfig
        Log-odds increments and clamp.
    """
    passed, hit_index = ray_cells(origin, ends, hit, logodds.shape[1])
    flat = logodds.reshape(-1)
    before = flat[hit_index]
    values = flat[passed]
    values += np.float32(config.log_odds_miss)
    np.maximum(values, np.float32(config.log_odds_min), out=values)
    flat[passed] = values
    before += np.float32(config.log_odds_hit)
    np.minimum(before, np.float32(config.log_odds_max), out=before)
    flat[hit_index] = before
    seen = observed.reshape(-1)
    seen[passed] = True
    seen[hit_index] = True


def ros_codes(logodds: NDArray[np.float32], observed: NDArray[np.bool_]) -> NDArray[np.int8]:
    """The ROS coding of a log-odds grid: ``round(100 / (1 + exp(-l)))`` where observed
    (computed in double precision, halves rounded up), ``-1`` elsewhere."""
    percent = 100.0 / (1.0 + np.exp(-logodds.astype(np.float64))) + 0.5
    codes = np.floor(percent).astype(np.int8)
    codes[~observed] = UNKNOWN
    return codes


class LogOddsMap:
    """A log-odds occupancy grid in one robot's frame that grows as needed.

    Parameters
    ----------
    config : MappingConfig
        Resolution, log-odds model and growth.

    Attributes
    ----------
    logodds : (rows, cols) float32 ndarray
        Log-odds per cell, row 0 at ``origin``.
    observed : (rows, cols) bool ndarray
        Cells any scan has touched.
    origin : (float, float)
        Map-frame coordinates (metres) of the outer corner of cell ``(0, 0)``;
        always a whole number of cells from the frame's origin.
    journal : list of (K, 2) int64 ndarray or None
        When a list (see :meth:`start_journal`), every update appends the
        lattice cells ``(a, b)`` it observed for the first time (cell
        ``(row, col)`` is lattice cell ``(col + a0, row + b0)``, ``(a0, b0)``
        the lattice index of cell ``(0, 0)``: ``origin / resolution``).
    """

    __slots__ = (
        "_cells",
        "_scans",
        "_scratch",
        "_stamps",
        "_wanted",
        "config",
        "journal",
        "logodds",
        "observed",
        "origin",
    )

    def __init__(self, config: MappingConfig | None = None) -> None:
        self.config = config if config is not None else MappingConfig()
        side = max(1, math.ceil(self.config.initial_extent / self.config.resolution))
        self.logodds = np.zeros((side, side), dtype=np.float32)
        self.observed = np.zeros((side, side), dtype=bool)
        corner = -(side // 2) * self.config.resolution
        self.origin = (corner, corner)
        # The ROS-coded grid, recoded cell by cell as scans change cells, per cell the
        # number of the last scan that passed it and whether it is saturated (the
        # kernel's stamps), and the kernel's working memory, kept between scans.
        self._cells = np.full((side, side), UNKNOWN, dtype=np.int8)
        self._stamps = np.zeros((side, side), dtype=STAMP_DTYPE)
        self._scans = 0
        self._scratch = np.zeros(0, dtype=np.int64)
        self._wanted = np.zeros(4)  # what the kernel asks for before it can integrate
        self.journal: list[NDArray[np.int64]] | None = None

    @property
    def shape(self) -> tuple[int, int]:
        """``(rows, cols)`` currently allocated."""
        return (int(self.logodds.shape[0]), int(self.logodds.shape[1]))

    @property
    def anchor(self) -> tuple[int, int]:
        """Lattice index ``(a0, b0)`` of cell ``(0, 0)`` (``origin`` in whole cells)."""
        res = self.config.resolution
        return round(self.origin[0] / res), round(self.origin[1] / res)

    @property
    def cells(self) -> NDArray[np.int8]:
        """The ROS-coded grid as it is now: a read-only view that later updates change
        (:meth:`to_occupancy_grid` gives a copy)."""
        view = self._cells.view()
        view.flags.writeable = False
        return view

    def start_journal(self) -> None:
        """Record from now on the cells each update observes first (``journal``)."""
        self.journal = []

    def take_journal(self) -> NDArray[np.int64]:
        """``(K, 2)`` lattice cells ``(a, b)`` first observed since the last call, emptied."""
        if self.journal is None:
            raise RuntimeError("the journal is off; call start_journal() first")
        entries = self.journal
        self.journal = []
        if len(entries) == 1:  # one update since the last call, as in a simulation step
            return entries[0]
        return np.concatenate(entries) if entries else np.zeros((0, 2), dtype=np.int64)

    def to_cells(self, points: ArrayLike) -> NDArray[np.float64]:
        """``(N, 2)`` map-frame metres to cell coordinates (centres at integers)."""
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        return (pts - np.asarray(self.origin)) / self.config.resolution - 0.5

    def ensure_contains(self, low: ArrayLike, high: ArrayLike) -> None:
        """Grow the grid so that the box ``low..high`` (metres) lies inside it.

        Growth adds ``growth_padding`` beyond the box on each side that was
        too small, in whole cells, and keeps every existing cell's place.
        """
        res = self.config.resolution
        rows, cols = self.shape
        (lx, ly), (hx, hy) = (tuple(float(v) for v in np.ravel(p)) for p in (low, high))
        ox, oy = self.origin
        cell_low = (math.floor((lx - ox) / res), math.floor((ly - oy) / res))
        cell_high = (math.floor((hx - ox) / res), math.floor((hy - oy) / res))
        if min(cell_low) >= 0 and cell_high[0] <= cols - 1 and cell_high[1] <= rows - 1:
            return
        extra = math.ceil(self.config.growth_padding / res)
        left, bottom = (-c + extra if c < 0 else 0 for c in cell_low)
        right = cell_high[0] - (cols - 1) + extra if cell_high[0] > cols - 1 else 0
        top = cell_high[1] - (rows - 1) + extra if cell_high[1] > rows - 1 else 0
        widths = ((bottom, top), (left, right))
        self.logodds = np.pad(self.logodds, widths)
        self.observed = np.pad(self.observed, widths)
        self._cells = np.pad(self._cells, widths, constant_values=UNKNOWN)
        self._stamps = np.pad(self._stamps, widths)
        self.origin = (ox - left * res, oy - bottom * res)

    def update(self, pose: ArrayLike, scan: Scan) -> None:
        """Integrate ``scan`` taken at ``pose = (x, y, theta)`` (map frame, metres, radians)."""
        x, y, theta = (float(v) for v in np.asarray(pose, dtype=float))
        if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(theta)):
            raise ValueError(f"pose must be finite, got {(x, y, theta)}")
        _check_scan(scan)
        self._integrate(x, y, theta, scan.angles, scan.ranges, scan.max_range)

    def _integrate(
        self,
        x: float,
        y: float,
        theta: float,
        angles: NDArray[np.float64],
        ranges: NDArray[np.float64],
        max_range: float,
    ) -> None:
        """:meth:`update` with its arguments checked (a finite pose, one angle per range)."""
        cfg = self.config
        room_checked = False
        while True:
            # Scan numbers run 1..127 and start again on stamps whose numbers are
            # cleared (the saturation flags stay).
            self._scans = self._scans % SCAN_NUMBER_BITS + 1
            if self._scans == 1:
                np.bitwise_and(self._stamps, STAMP_DTYPE(SATURATED), out=self._stamps)
            a0, b0 = self.anchor
            status, fresh = update_grid(
                self.logodds,
                self.observed,
                self._cells,
                self._stamps,
                self._scans,
                self.origin[0],
                self.origin[1],
                cfg.resolution,
                x,
                y,
                theta,
                angles,
                ranges,
                max_range,
                cfg.carve_no_return,
                room_checked,
                cfg.log_odds_hit,
                cfg.log_odds_miss,
                cfg.log_odds_min,
                cfg.log_odds_max,
                SAMPLE_STEP_CELLS,
                HIT_DEPTH_CELLS,
                CODE_THRESHOLDS,
                a0,
                b0,
                self._scratch,
                self._wanted,
            )
            if status == INTEGRATED:
                break
            if status == GROW_SCRATCH:
                self._scratch = np.empty(int(self._wanted[0]), dtype=np.int64)
                continue
            # The quick test of the kernel failed; ensure_contains applies the exact one
            # (the scan needs half the room it asks for).
            self.ensure_contains(self._wanted[:2], self._wanted[2:])
            room_checked = True
        if self.journal is not None and len(fresh):
            self.journal.append(fresh)

    def probability(self) -> NDArray[np.float64]:
        """``(rows, cols)`` occupancy probability, ``nan`` where never observed."""
        prob = 1.0 / (1.0 + np.exp(-self.logodds.astype(np.float64)))
        prob[~self.observed] = np.nan
        return prob

    def to_occupancy_grid(self) -> OccupancyGrid:
        """The map as an :class:`~merging.grid.OccupancyGrid` in the robot's frame (a copy).

        Cell ``(0, 0)``'s corner is at ``origin`` (yaw 0): the frame is the
        robot's odometry frame, whose origin is its start pose.
        """
        return OccupancyGrid(
            self._cells.copy(),
            resolution=self.config.resolution,
            origin=(self.origin[0], self.origin[1], 0.0),
        )


def update_maps(
    maps: Sequence[LogOddsMap],
    poses: ArrayLike,
    angles: NDArray[np.float64],
    ranges: NDArray[np.float64],
    max_range: float,
) -> None:
    """Integrate one scan into each of ``maps``, the arguments checked once for all.

    The same as ``maps[k].update(poses[k], Scan(angles, ranges[k], max_range))``
    for each ``k`` in turn, as a team's simulation step does.

    Parameters
    ----------
    maps : sequence of N LogOddsMap
    poses : (N, 3) array_like
        Pose of each scan in its map's frame ``(x, y, theta)``, metres and radians.
    angles : (B,) float ndarray
        Beam directions relative to the heading, shared by the scans.
    ranges : (N, B) float ndarray
        Each scan's ranges (:class:`tomosim.lidar.Scan`).
    max_range : float
        The lidar's range limit, metres.
    """
    pose_rows = np.asarray(poses, dtype=float)
    values = pose_rows.tolist()
    if pose_rows.shape != (len(maps), 3) or not all(
        math.isfinite(v) for pose in values for v in pose
    ):
        raise ValueError(
            f"poses must be finite, one (x, y, theta) per map: shape ({len(maps)}, 3), "
            f"got {pose_rows.shape}"
        )
    if ranges.ndim != 2 or len(ranges) != len(maps):
        raise ValueError(f"ranges must hold one row per map ({len(maps)}), got {ranges.shape}")
    _check_layout(angles, ranges.shape[1:], max_range)  # the layout all rows share
    for grid_map, (x, y, theta), row in zip(maps, values, ranges, strict=True):
        grid_map._integrate(x, y, theta, angles, row, max_range)
