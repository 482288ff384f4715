"""Track a known transform between two growing maps: refine from the last one, verify.

Once two maps have been merged, the next merge of the same pair sees the
same maps grown a little; the transform between their frames moves only by
odometry drift. :func:`track_transform` therefore skips the global search of
:mod:`merging.tomographic` and refines the previous transform, carried onto
the maps' current cells, with :func:`merging.tomographic.search.refine_from` (the
default method's refinement and confidence, without a runner-up or the
search for map 2's mirror image: the global search the track began from held
its transform against both, and a caller searches again every few rounds).
It keeps a transform from jumping between rounds and costs a fraction of a
search.

With no runner-up to compare with, a tracked transform is also refused when
the refinement moved it further than :data:`MAX_TRACK_ROTATION_DEG` or
:data:`MAX_TRACK_TRANSLATION_CELLS` from where it started: a drift that large
means the track is lost, and the caller should search globally again (as it
should every few rounds anyway).
"""

from __future__ import annotations

import math
import time
from dataclasses import replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from merging.api import MIN_OCCUPIED_CELLS
from merging.grid import OccupancyGrid, occupied_mask
from merging.params import DEFAULT_PARAMS, TomographicParams
from merging.result import MergeResult
from merging.tomographic.search import refine_from
from merging.transforms import cells_to_metres, matrix_to_pose

MAX_TRACK_ROTATION_DEG = 3.0
"""Degrees a tracked transform may turn from its start: odometry drift between two
rounds turns a frame by well under a degree."""
MAX_TRACK_TRANSLATION_CELLS = 10.0
"""Cells (0.5 m at 0.05 m) a tracked transform may move map 2's origin from its start."""
METHOD = "tomographic-tracked"
"""The ``method`` of a tracked result."""


def track_transform(
    map1: OccupancyGrid,
    map2: OccupancyGrid,
    previous: ArrayLike,
    *,
    params: TomographicParams = DEFAULT_PARAMS,
) -> MergeResult:
    """Refine and verify a known transform of ``map2``'s frame into ``map1``'s.

    Parameters
    ----------
    map1, map2 : OccupancyGrid
        The maps now, in the ROS coding, at one resolution.
    previous : (3, 3) array_like
        Rigid matrix taking ``map2``'s frame to ``map1``'s, metres (a
        :attr:`MergeResult.matrix_metres` of an earlier round).
    params : TomographicParams
        The default method's settings (``from_start`` is the refinement).

    Returns
    -------
    MergeResult
        ``matrix`` (cells, eq. 1 of the paper) and ``matrix_metres`` refined;
        ``accepted`` when :func:`~merging.tomographic.search.refine_from` accepts the
        refined transform and it stayed near its start; ``reason`` says why
        not otherwise.
    """
    clock = time.perf_counter()
    start = np.asarray(previous, dtype=np.float64)
    if start.shape != (3, 3) or not np.all(np.isfinite(start)):
        raise ValueError(f"previous must be a finite 3x3 matrix, got shape {start.shape}")
    if not (isinstance(map1, OccupancyGrid) and isinstance(map2, OccupancyGrid)):
        raise TypeError("track_transform needs two OccupancyGrids (their frames place the cells)")
    if not np.isclose(map1.resolution, map2.resolution):
        raise ValueError(f"map resolutions differ ({map1.resolution} m vs {map2.resolution} m)")
    initial = frame_to_cells(start, map1, map2)
    counts = (int(occupied_mask(map1.data).sum()), int(occupied_mask(map2.data).sum()))
    if min(counts) < MIN_OCCUPIED_CELLS:
        why = f"too few occupied cells to match (map1 {counts[0]}, map2 {counts[1]})"
        return MergeResult(initial, 0.0, False, METHOD, start, reason=why)
    result = refine_from(map1, map2, initial, params=params)
    dx, dy, turn = matrix_to_pose(np.linalg.inv(initial) @ result.matrix)
    moved = math.hypot(dx, dy)
    reason = result.reason
    if abs(math.degrees(turn)) > MAX_TRACK_ROTATION_DEG or moved > MAX_TRACK_TRANSLATION_CELLS:
        reason = (
            f"track lost: the refinement moved {math.degrees(turn):.1f} deg and "
            f"{moved:.1f} cells from the previous transform"
        )
    timings = {**result.timings, "total": time.perf_counter() - clock}
    return replace(
        result,
        accepted=result.accepted and not reason,
        method=METHOD,
        matrix_metres=cells_to_metres(result.matrix, map1, map2),
        timings=timings,
        reason=reason,
    )


def frame_to_cells(
    matrix: ArrayLike, map1: OccupancyGrid, map2: OccupancyGrid
) -> NDArray[np.float64]:
    """A transform between the maps' frames (metres) as one between their cells (eq. 1):
    ``inv(W1) @ M @ W2``, the inverse of :func:`merging.transforms.cells_to_metres`."""
    frames = np.asarray(matrix, dtype=np.float64)
    return np.asarray(
        np.linalg.inv(map1.cell_to_world_matrix()) @ frames @ map2.cell_to_world_matrix(),
        dtype=np.float64,
    )


def frame_matrix(result: MergeResult) -> NDArray[np.float64] | None:
    """The metre transform of ``result`` when it is finite, else None."""
    metres = result.matrix_metres
    if metres is None or not np.all(np.isfinite(metres)):
        return None
    return np.asarray(metres, dtype=np.float64)
