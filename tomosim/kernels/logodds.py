"""One scan integrated into a log-odds grid and its ROS-coded copy, compiled.

The inverse sensor model is that of :func:`tomosim.mapping.integrate_rays`
(its specification and test oracle), computed with the same single-precision
sample positions, so both mark the same cells, and :func:`integrate_scan`
lists the cells it observes first in the order the oracle's samples reach
them. A scan has some 26,000 samples (360 beams of 8 m at 5 cm), half of
them near the sensor, where many beams cross the same cells, and most of
them on cells already known to be free. The kernel:

1. computes each beam's sample cells in a loop the compiler vectorises
   (:func:`beam_cells`), into a buffer that stays in the first-level cache;
2. finds each cell's first pass in this scan through a *stamp* grid holding,
   per cell, the number of the last scan that passed it: one byte read and
   written per sample, without a branch on the data (the index of every
   sample is stored and kept by advancing a count by one or zero; a branch
   would be mispredicted at random near the sensor);
3. skips the cells whose log-odds sits at ``log_odds_min`` already, which a
   pass cannot change, known from a flag bit of the same stamp
   (:data:`SATURATED`), so that the log-odds grid is read only at cells that
   can change: the free space the robot has seen a few times is nearly all
   that it sees, so a beam's samples up to its first cell that is not
   saturated are only read, not stamped (a saturated cell's scan number is
   never looked at);
4. applies one ``log_odds_miss`` to each cell passed, then the hits;
5. recodes, in the ROS coding of :func:`tomosim.mapping.ros_codes`, exactly
   the cells whose log-odds changed, so that the exported grid is never
   converted in full, and returns the flat indices of the cells observed for
   the first time, from which the team coverage is kept up to date without
   scanning grids.

Indices are unsigned, so that the compiled code skips the wrap-around of
negative indices. A *scratch* buffer, kept by the caller from scan to scan,
holds the sample cells and the changed cells (:func:`update_grid` says when it
is too small). Each kernel hands back one array at most: every array returned
to Python costs about a microsecond to box.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from tomosim.kernels.jit import kernel

UNKNOWN_CODE = -1
"""ROS code of a cell never observed."""
SATURATED = 0x80
"""Stamp bit set exactly while a cell's log-odds equals ``log_odds_min``: a pass leaves
such a cell as it is, so passes skip it."""
SCAN_NUMBER_BITS = 0x7F
"""The stamp bits holding a scan number: numbers run 1..127; a caller starting them
again clears these bits of every stamp and keeps :data:`SATURATED`."""
INTEGRATED = 0
"""Status of :func:`update_grid`: the scan was integrated."""
GROW_GRID = 1
"""Status of :func:`update_grid`: the grid must grow first."""
GROW_SCRATCH = 2
"""Status of :func:`update_grid`: the scratch memory must grow first."""
SAMPLES_MARGIN = 3
"""Samples added to a beam's length in cells when bounding its samples: one for the
ceiling, one for a beam of no length (one sample), one for rounding."""
CODE_TABLE_SIZE = 128
"""Entries of :func:`code_thresholds`: the 100 thresholds padded with ``inf`` to a power
of two, so that a search halves it without a bound check."""


def code_thresholds() -> NDArray[np.float64]:
    """``(128,)`` log-odds at which the ROS code steps from ``p - 1`` to ``p``, ``p = 1..100``,
    then ``inf`` (:data:`CODE_TABLE_SIZE`).

    ``round(100 / (1 + exp(-l)))`` (halves up) reaches ``p`` where the
    probability reaches ``(p - 0.5) / 100``, at ``l = log(q / (1 - q))``;
    counting the thresholds at or below ``l`` gives the code without an
    exponential per cell.
    """
    q = (np.arange(1, 101) - 0.5) / 100.0
    table = np.full(CODE_TABLE_SIZE, np.inf)
    table[:100] = np.log(q / (1.0 - q))
    return table


@kernel
def ros_code(value: float, thresholds: NDArray[np.float64]) -> int:
    """ROS code of an observed cell of finite log-odds ``value`` (:func:`code_thresholds`):
    the number of thresholds at or below it, by halving the table (no branch on the data)."""
    position = 0
    half = CODE_TABLE_SIZE // 2
    while half > 0:
        probe = position + half
        position = probe if thresholds[probe - 1] <= value else position
        half //= 2
    return position


@kernel
def beam_cells(
    step_x: np.float32,
    step_y: np.float32,
    offset_x: np.float32,
    offset_y: np.float32,
    samples: int,
    cols: int,
    out: NDArray[np.int64],
) -> None:
    """Flat cell index of sample ``j`` of a beam, ``j < samples``, into ``out[j]``.

    Sample ``j`` lies at ``(step_x * j + offset_x, step_y * j + offset_y)`` in
    single precision, the offsets being the sensor position plus half a cell
    (cell ``(col, row)`` spans ``[col, col + 1)`` there); positions are
    non-negative (inside the grid), so truncation is the floor.
    """
    for j in range(samples):
        along = np.float32(np.int32(j))
        x = step_x * along + offset_x
        y = step_y * along + offset_y
        out[j] = np.int64(np.int32(y)) * cols + np.int64(np.int32(x))


@kernel
def integrate_scan(
    logodds: NDArray[np.float32],
    observed: NDArray[np.bool_],
    codes: NDArray[np.int8],
    stamps: NDArray[np.uint8],
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
    scratch: NDArray[np.int64],
) -> NDArray[np.int64]:
    """Apply one scan in place (the model of :func:`tomosim.mapping.integrate_rays`).

    Parameters
    ----------
    logodds : (rows, cols) float32 ndarray
        Log-odds per cell, C-contiguous; updated in place.
    observed : (rows, cols) bool ndarray
        Set for every cell the scan touches.
    codes : (rows, cols) int8 ndarray
        The ROS-coded grid, ``-1`` exactly where ``observed`` is False; the cells
        whose log-odds the scan changes are recoded.
    stamps : (rows, cols) uint8 ndarray
        Per cell, the number of the last scan that passed it and the
        :data:`SATURATED` bit; updated. All zeros for a new grid.
    scan_id : int
        A scan number in ``1..127`` that no stamp holds.
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
    thresholds : (128,) float ndarray
        :func:`code_thresholds`.
    scratch : (S,) int64 ndarray
        Working memory: at least the scan's samples, plus one per beam and the
        samples of its longest beam (:func:`update_grid` bounds it); a smaller one
        raises ValueError.

    Returns
    -------
    (K,) int64 ndarray
        Flat indices (``row * cols + col``) of the cells observed for the first
        time, in the order of the samples (beam by beam, from the sensor out)
        that first changed them, then of the hits.
    """
    cols = logodds.shape[1]
    flat = logodds.ravel()
    seen = observed.ravel()
    coded = codes.ravel()
    stamp = stamps.ravel()
    beams = ends.shape[0]
    miss = np.float32(log_odds_miss)
    low = np.float32(log_odds_min)
    high = np.float32(log_odds_max)
    offset_x = np.float32(origin_x + 0.5)
    offset_y = np.float32(origin_y + 0.5)
    # Samples per beam (sample j of n at origin + j / n * (end - origin)), and the hit
    # cells with their values before the scan (a hit wins over a pass).
    samples = np.empty(beams, dtype=np.int64)
    hit_cells = np.empty(beams, dtype=np.int64)
    hit_before = np.empty(beams, dtype=np.float32)
    hits = 0
    total = 0
    longest = 0
    for i in range(beams):
        dx = ends[i, 0] - origin_x
        dy = ends[i, 1] - origin_y
        length = math.hypot(dx, dy)
        samples[i] = max(math.ceil(length / sample_step), 1)
        total += samples[i]
        longest = max(longest, samples[i])
        if not hit[i]:
            continue
        depth = hit_depth / max(length, 2.2250738585072014e-308)
        col = math.floor(ends[i, 0] + dx * depth + 0.5)
        row = math.floor(ends[i, 1] + dy * depth + 0.5)
        cell = row * cols + col
        hit_cells[hits] = cell
        hit_before[hits] = flat[cell]
        hits += 1
    if scratch.shape[0] < total + hits + longest:
        raise ValueError("the scratch memory is too small for this scan; see update_grid")
    beam = scratch[total + hits :]  # one beam's sample cells, after the room for the lists
    now = np.uint8(scan_id)
    # Steps 1-3: the first pass of each cell not saturated, in the order of the samples.
    passed = np.uint64(0)
    for i in range(beams):
        n = samples[i]
        step_x = np.float32((ends[i, 0] - origin_x) / n)
        step_y = np.float32((ends[i, 1] - origin_y) / n)
        beam_cells(step_x, step_y, offset_x, offset_y, n, cols, beam)
        first = 0  # the beam's leading run of saturated cells needs no stamping
        while first < n and stamp[np.uint64(beam[first])] >= np.uint8(SATURATED):
            first += 1
        for j in range(first, n):
            cell = np.uint64(beam[j])
            mark = stamp[cell]
            stamp[cell] = (mark & np.uint8(SATURATED)) | now
            scratch[passed] = cell
            passed += np.uint64((mark != now) & (mark < np.uint8(SATURATED)))
    # Step 4: one miss per cell passed, then the hits; the changed cells are kept.
    changed = np.uint64(0)
    for t in range(passed):
        cell = np.uint64(scratch[t])
        before = flat[cell]
        value = before + miss
        value = value if value > low else low
        flat[cell] = value
        stamp[cell] |= np.uint8(SATURATED) * np.uint8(value == low)
        scratch[changed] = cell
        changed += np.uint64(value != before)
    for h in range(hits):
        cell = np.uint64(hit_cells[h])
        value = hit_before[h] + np.float32(log_odds_hit)
        value = value if value < high else high
        current = flat[cell]
        flat[cell] = value
        stamp[cell] &= np.uint8(SCAN_NUMBER_BITS)
        scratch[changed] = cell
        changed += np.uint64(value != current)
    # Step 5: recode what changed; the cells unknown until now are the fresh ones.
    fresh = np.empty(changed, dtype=np.int64)
    new = 0
    for t in range(changed):
        cell = np.uint64(scratch[t])
        if coded[cell] == UNKNOWN_CODE:
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
    stamps: NDArray[np.uint8],
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
    scratch: NDArray[np.int64],
    wanted: NDArray[np.float64],
) -> tuple[int, NDArray[np.int64]]:
    """One scan into a grid whose cell ``(0, 0)`` has its corner at ``(grid_x, grid_y)`` metres.

    The steps of :meth:`tomosim.mapping.LogOddsMap.update` in one call:
    :func:`beam_ends`, the check that the grid holds the beams with a cell of
    room (unless ``room_checked``), the end points in cell coordinates, and
    :func:`integrate_scan`. Arguments are those of the two kernels, the pose
    ``(pose_x, pose_y, pose_theta)``, the scan's ``angles``, ``ranges`` and
    ``max_range``, the lattice index ``(anchor_a, anchor_b)`` of cell ``(0, 0)``,
    the scratch memory of :func:`integrate_scan`, and ``wanted``, a ``(4,)`` array
    that says what the caller must do first when the scan was not integrated.

    Returns
    -------
    status : int
        :data:`INTEGRATED`; :data:`GROW_GRID`: nothing was changed, the grid must
        first be grown to hold the box ``wanted = (xmin, ymin, xmax, ymax)``,
        metres; :data:`GROW_SCRATCH`: nothing was changed, the scratch memory
        must first hold ``wanted[0]`` cells.
    fresh : (K, 2) int64 ndarray
        Lattice cells ``(a, b)`` observed for the first time, in the order of
        :func:`integrate_scan` (none unless integrated).
    """
    none = np.zeros((0, 2), dtype=np.int64)
    ends, hit, box = beam_ends(
        pose_x, pose_y, pose_theta, angles, ranges, max_range, carve_no_return
    )
    if ends.shape[0] == 0:
        return INTEGRATED, none
    # One cell of room beyond the end points for the hit cells (the hit depth).
    room = resolution
    rows, cols = logodds.shape
    if not room_checked and not (
        box[0] - room >= grid_x
        and box[1] - room >= grid_y
        and box[2] + room < grid_x + cols * room
        and box[3] + room < grid_y + rows * room
    ):
        wanted[0], wanted[1] = box[0] - room, box[1] - room
        wanted[2], wanted[3] = box[2] + room, box[3] + room
        return GROW_GRID, none
    # A beam is no longer than the farthest corner of the box from the sensor.
    reach = math.hypot(max(box[2] - pose_x, pose_x - box[0]), max(box[3] - pose_y, pose_y - box[1]))
    per_beam = int(reach / resolution / sample_step) + SAMPLES_MARGIN
    if scratch.shape[0] < ends.shape[0] * (per_beam + 1) + per_beam:
        wanted[0] = ends.shape[0] * (per_beam + 1) + per_beam
        return GROW_SCRATCH, none
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
        scratch,
    )
    lattice = np.empty((fresh.shape[0], 2), dtype=np.int64)
    for k in range(fresh.shape[0]):
        lattice[k, 0] = fresh[k] % cols + anchor_a
        lattice[k, 1] = fresh[k] // cols + anchor_b
    return INTEGRATED, lattice
