"""One scan integrated into a log-odds grid and its ROS-coded copy, compiled.

The inverse sensor model is that of :func:`tomosim.mapping.integrate_rays`
(its specification and test oracle), computed with the same single-precision
sample positions, so both mark the same cells. Instead of fancy-indexed
gathers, each cell passed is counted once per scan through a *stamp* grid
holding the number of the last scan that passed it.

The loop over a scan's samples (some 26,000 for 360 beams of 8 m at 5 cm, half
of them near the sensor, where many beams cross the same cells) has no branch
that depends on the data: whether a cell was passed before in this scan changes
*what* is written (its new value, or its old one again), not *whether*, and the
index of a changed cell is always stored and kept by advancing the count by
one or zero. A branch there would be mispredicted at random near the sensor;
without it the loop costs about 60 % of what it did. Indices are unsigned, so
that the compiled code skips the wrap-around of negative indices. The kernel also

* recodes, in the ROS coding of :func:`tomosim.mapping.ros_codes`, exactly
  the cells the scan changed, so that the exported grid is never converted
  in full;
* returns the flat indices of the cells observed for the first time, from
  which the team coverage is kept up to date without scanning grids.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tomosim.kernels.jit import kernel

UNKNOWN_CODE = -1
"""ROS code of a cell never observed."""


def code_thresholds() -> NDArray[np.float64]:
    """``(100,)`` log-odds at which the ROS code steps from ``p - 1`` to ``p``, ``p = 1..100``.

    ``round(100 / (1 + exp(-l)))`` (halves up) reaches ``p`` where the
    probability reaches ``(p - 0.5) / 100``, at ``l = log(q / (1 - q))``;
    counting the thresholds at or below ``l`` gives the code without an
    exponential per cell.
    """
    q = (np.arange(1, 101) - 0.5) / 100.0
    return np.log(q / (1.0 - q))


@kernel
def ros_code(value: float, thresholds: NDArray[np.float64]) -> int:
    """ROS code of an observed cell of log-odds ``value`` (:func:`code_thresholds`)."""
    return int(np.searchsorted(thresholds, value, side="right"))


@kernel
def integrate_scan(
    logodds: NDArray[np.float32],
    observed: NDArray[np.bool_],
    codes: NDArray[np.int8],
    stamps: NDArray[np.unsignedinteger[Any]],
    scan_id: int,
    origin_x: float,
    origin_y: float,
    ends: NDArray[np.float64],
    hit: NDArray[np.bool_],
    log_odds_hit: float,
    log_odds_miss: float,
    log_odds_min: float,
    log_odds_max: float,
    sample_step: float,
    hit_depth: float,
    thresholds: NDArray[np.float64],
) -> NDArray[np.int64]:
    """Apply one scan in place (the model of :func:`tomosim.mapping.integrate_rays`).

    Parameters
    ----------
    logodds : (rows, cols) float32 ndarray
        Log-odds per cell, C-contiguous; updated in place.
    observed : (rows, cols) bool ndarray
        Set for every cell the scan touches.
    codes : (rows, cols) int8 ndarray
        The ROS-coded grid; the cells the scan touches are recoded.
    stamps : (rows, cols) unsigned integer ndarray
        Per cell, the ``scan_id`` of the last scan that passed it; updated.
    scan_id : int
        A number no cell's stamp holds, and that fits the stamps' type.
    origin_x, origin_y : float
        Sensor position in cell coordinates ``(x, y) = (col, row)``.
    ends : (M, 2) float ndarray
        Beam end points in cell coordinates, inside the grid like the origin.
    hit : (M,) bool ndarray
        Whether each beam's end point is an obstacle.
    log_odds_hit, log_odds_miss, log_odds_min, log_odds_max : float
        The model of :class:`tomosim.mapping.MappingConfig`.
    sample_step : float
        Cells between samples along a beam.
    hit_depth : float
        Cells beyond the end point at which a return marks its cell.
    thresholds : (100,) float ndarray
        :func:`code_thresholds`.

    Returns
    -------
    (K,) int64 ndarray
        Flat indices (``row * cols + col``) of the cells observed for the first time.
    """
    cols = logodds.shape[1]
    flat = logodds.ravel()
    seen = observed.ravel()
    coded = codes.ravel()
    stamp = stamps.ravel()
    beams = ends.shape[0]
    miss = np.float32(log_odds_miss)
    low = np.float32(log_odds_min)
    offset_x = np.float32(origin_x + 0.5)
    offset_y = np.float32(origin_y + 0.5)
    # Hit cells and their values before the scan (a hit wins over a pass).
    hit_cells = np.empty(beams, dtype=np.int64)
    hit_before = np.empty(beams, dtype=np.float32)
    hits = 0
    for i in range(beams):
        if not hit[i]:
            continue
        dx = ends[i, 0] - origin_x
        dy = ends[i, 1] - origin_y
        depth = hit_depth / max(math.hypot(dx, dy), 2.2250738585072014e-308)
        col = math.floor(ends[i, 0] + dx * depth + 0.5)
        row = math.floor(ends[i, 1] + dy * depth + 0.5)
        cell = row * cols + col
        hit_cells[hits] = cell
        hit_before[hits] = flat[cell]
        hits += 1
    total = 0
    for i in range(beams):
        length = math.hypot(ends[i, 0] - origin_x, ends[i, 1] - origin_y)
        total += max(math.ceil(length / sample_step), 1)
    touched = np.empty(total + hits, dtype=np.int64)
    count = np.uint64(0)
    stamp_now = stamps.dtype.type(scan_id)
    # Passes: sample j of beam i at origin + j / n * (end - origin), j < n, once per cell.
    for i in range(beams):
        dx = ends[i, 0] - origin_x
        dy = ends[i, 1] - origin_y
        samples = max(math.ceil(math.hypot(dx, dy) / sample_step), 1)
        step_x = np.float32(dx / samples)
        step_y = np.float32(dy / samples)
        for j in range(samples):
            xs = step_x * np.float32(j) + offset_x
            ys = step_y * np.float32(j) + offset_y
            cell = np.uint64(np.int64(ys) * cols + np.int64(xs))
            first_pass = stamp[cell] != stamp_now
            stamp[cell] = stamp_now
            before = flat[cell]
            value = before + miss
            value = value if value > low else low
            # A cell passed before in this scan keeps its value (written back). A value
            # the clamp kept unchanged is the clamp (not 0): the cell was seen before
            # and keeps its code, so only changed cells are kept for recoding.
            value = value if first_pass else before
            flat[cell] = value
            touched[count] = cell
            count += np.uint64(value != before)
    for h in range(hits):
        value = hit_before[h] + np.float32(log_odds_hit)
        high = np.float32(log_odds_max)
        flat[hit_cells[h]] = value if value < high else high
        touched[count] = hit_cells[h]
        count += np.uint64(1)
    fresh = np.empty(count, dtype=np.int64)
    new = 0
    for t in range(count):
        cell = touched[t]
        if not seen[cell]:
            seen[cell] = True
            fresh[new] = cell
            new += 1
        coded[cell] = ros_code(flat[cell], thresholds)
    return fresh[:new]


@kernel
def beam_ends(
    x: float,
    y: float,
    theta: float,
    angles: NDArray[np.float64],
    ranges: NDArray[np.float64],
    max_range: float,
    carve_no_return: bool,
) -> tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.float64]]:
    """End points of the beams a scan integrates (step 2 of :mod:`tomosim.mapping`).

    Parameters
    ----------
    x, y, theta : float
        The pose the scan was taken at (map frame, metres, radians).
    angles, ranges : (B,) float ndarray
        The scan (:class:`tomosim.lidar.Scan`): ``inf`` no return, ``nan`` dropout.
    max_range : float
        Where a beam without return ends, metres.
    carve_no_return : bool
        Whether beams without return are integrated at all.

    Returns
    -------
    ends : (M, 2) float ndarray
        End points in metres of the beams used, in beam order.
    hit : (M,) bool ndarray
        Whether each used beam returned (its end is an obstacle).
    box : (4,) float ndarray
        ``(xmin, ymin, xmax, ymax)`` of the end points and the pose.
    """
    count = ranges.shape[0]
    ends = np.empty((count, 2))
    hit = np.empty(count, dtype=np.bool_)
    box = np.array([x, y, x, y])
    used = 0
    for k in range(count):
        value = ranges[k]
        if math.isnan(value):
            continue
        if not math.isfinite(angles[k]):
            raise ValueError("every beam angle of a scan must be finite")
        if value < 0.0 or (value > max_range and not math.isinf(value)):
            raise ValueError(
                "scan ranges must lie within [0, max_range] (inf: no return, nan: dropout)"
            )
        returned = not math.isinf(value)
        if not returned and not carve_no_return:
            continue
        length = value if returned else max_range
        bearing = theta + angles[k]
        ex = x + length * math.cos(bearing)
        ey = y + length * math.sin(bearing)
        ends[used, 0] = ex
        ends[used, 1] = ey
        hit[used] = returned
        box[0] = min(box[0], ex)
        box[1] = min(box[1], ey)
        box[2] = max(box[2], ex)
        box[3] = max(box[3], ey)
        used += 1
    return ends[:used], hit[:used], box


@kernel
def update_grid(
    logodds: NDArray[np.float32],
    observed: NDArray[np.bool_],
    codes: NDArray[np.int8],
    stamps: NDArray[np.unsignedinteger[Any]],
    scan_id: int,
    grid_x: float,
    grid_y: float,
    resolution: float,
    pose_x: float,
    pose_y: float,
    pose_theta: float,
    angles: NDArray[np.float64],
    ranges: NDArray[np.float64],
    max_range: float,
    carve_no_return: bool,
    room_checked: bool,
    log_odds_hit: float,
    log_odds_miss: float,
    log_odds_min: float,
    log_odds_max: float,
    sample_step: float,
    hit_depth: float,
    thresholds: NDArray[np.float64],
    anchor_a: int,
    anchor_b: int,
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """One scan into a grid whose cell ``(0, 0)`` has its corner at ``(grid_x, grid_y)`` metres.

    The steps of :meth:`tomosim.mapping.LogOddsMap.update` in one call:
    :func:`beam_ends`, the check that the grid holds the beams with a cell of
    room (unless ``room_checked``), the end points in cell coordinates, and
    :func:`integrate_scan`. Arguments are those of the two kernels, the pose
    ``(pose_x, pose_y, pose_theta)``, the scan's ``angles``, ``ranges`` and
    ``max_range``, and the lattice index ``(anchor_a, anchor_b)`` of cell ``(0, 0)``.

    Returns
    -------
    grow : (0,) or (4,) float ndarray
        Empty when the scan was integrated; else ``(xmin, ymin, xmax, ymax)``,
        metres, a box the grid must be grown to hold before the scan can be
        (nothing was changed).
    fresh : (K, 2) int64 ndarray
        Lattice cells ``(a, b)`` observed for the first time.
    """
    none = np.zeros((0, 2), dtype=np.int64)
    no_growth = np.zeros(0)
    ends, hit, box = beam_ends(
        pose_x, pose_y, pose_theta, angles, ranges, max_range, carve_no_return
    )
    if ends.shape[0] == 0:
        return no_growth, none
    # One cell of room beyond the end points for the hit cells (the hit depth).
    room = resolution
    rows, cols = logodds.shape
    if not room_checked and not (
        box[0] - room >= grid_x
        and box[1] - room >= grid_y
        and box[2] + room < grid_x + cols * room
        and box[3] + room < grid_y + rows * room
    ):
        return np.array([box[0] - room, box[1] - room, box[2] + room, box[3] + room]), none
    cells = np.empty_like(ends)
    for i in range(ends.shape[0]):
        cells[i, 0] = (ends[i, 0] - grid_x) / resolution - 0.5
        cells[i, 1] = (ends[i, 1] - grid_y) / resolution - 0.5
    fresh = integrate_scan(
        logodds,
        observed,
        codes,
        stamps,
        scan_id,
        (pose_x - grid_x) / resolution - 0.5,
        (pose_y - grid_y) / resolution - 0.5,
        cells,
        hit,
        log_odds_hit,
        log_odds_miss,
        log_odds_min,
        log_odds_max,
        sample_step,
        hit_depth,
        thresholds,
    )
    lattice = np.empty((fresh.shape[0], 2), dtype=np.int64)
    for k in range(fresh.shape[0]):
        lattice[k, 0] = fresh[k] % cols + anchor_a
        lattice[k, 1] = fresh[k] // cols + anchor_b
    return no_growth, lattice
