"""How right a merge is: estimated against true relative transforms between robots' map frames.

Each robot's map frame is its true start pose, which only the simulator knows.
The true transform taking robot ``j``'s map frame to robot ``i``'s, in metres,
is ``inv(P_i) @ P_j`` with ``P_k = pose_matrix(start_k)``; a merge estimates the
same transform from the two grids alone (``MergeResult.matrix_metres``).

The errors compare the two transforms as poses ``(x, y, yaw)`` of frame ``j``
in frame ``i``:

* **rotation error**: ``|wrap(yaw_est - yaw_true)|`` in degrees, in ``[0, 180]``;
* **translation error**: ``|t_est - t_true|`` in metres, the distance between
  where the estimate and the truth put robot ``j``'s start position in robot
  ``i``'s frame.

Both grids are built at drifting odometry poses, so even a merge that lays the
two grids perfectly over each other keeps an error of the order of the drift.

:func:`merged_agreement` scores a merged map as a whole against the ground truth;
:func:`score_round` scores a whole merge round, which the merger made without
the truth (:class:`~tomosim.team.merger.TeamMerger`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from merging.evaluation.metrics import acceptance_index, matching_index
from merging.grid import OccupancyGrid, free_mask
from merging.transforms import matrix_to_pose
from tomosim.frames import frame_errors, pose_matrix
from tomosim.kernels.overlap import shared_free
from tomosim.team.merger import PairOutcome, TeamMerge, pair_name, robot_name

TRUTH_WINDOW_MARGIN = 2
"""Cells of truth kept around the merged map's footprint when comparing the two;
the comparison only counts cells both know, so the window only saves time."""
NO_ESTIMATE = math.inf
"""Error reported when a method returned no finite transform: larger than any real error."""


def _triple(values: ArrayLike) -> tuple[float, float, float]:
    """Three numbers as a tuple of floats."""
    x, y, yaw = (float(v) for v in np.asarray(values, dtype=float))
    return (x, y, yaw)


def true_relative(start_i: ArrayLike, start_j: ArrayLike) -> NDArray[np.float64]:
    """The 3x3 rigid matrix taking robot ``j``'s map frame to robot ``i``'s (metres).

    Parameters
    ----------
    start_i, start_j : (3,) array_like
        True start poses ``(x, y, theta)`` in the world (metres, radians).
    """
    return np.asarray(np.linalg.inv(pose_matrix(start_i)) @ pose_matrix(start_j), dtype=np.float64)


def in_cells(
    grid_i: OccupancyGrid, grid_j: OccupancyGrid, metres: NDArray[np.float64]
) -> NDArray[np.float64]:
    """``metres`` (frame ``j`` to frame ``i``) as the matrix taking grid ``j``'s cells to
    grid ``i``'s: ``inv(C_i) @ metres @ C_j`` (:meth:`OccupancyGrid.cell_to_world_matrix`)."""
    into_i = np.linalg.inv(grid_i.cell_to_world_matrix())
    return np.asarray(into_i @ metres @ grid_j.cell_to_world_matrix(), dtype=np.float64)


def shared_free_area(
    grid_i: OccupancyGrid, grid_j: OccupancyGrid, cells: NDArray[np.float64]
) -> float:
    """Square metres of free space both grids know: grid ``j``'s free cells whose
    centres ``cells`` (grid ``j``'s cells to grid ``i``'s) carries onto free cells of
    grid ``i``, each counting grid ``j``'s cell area.

    Counted by the compiled :func:`tomosim.kernels.overlap.shared_free`;
    :func:`shared_free_numpy` is its specification.
    """
    matrix = np.ascontiguousarray(cells, dtype=np.float64)
    if matrix.shape != (3, 3) or not np.all(np.isfinite(matrix)):
        raise ValueError(
            f"cells must be a finite 3x3 matrix (grid j's cells to grid i's), got {cells!r}"
        )
    count = shared_free(
        np.ascontiguousarray(grid_i.data), np.ascontiguousarray(grid_j.data), matrix
    )
    return float(count) * grid_j.resolution**2


def shared_free_numpy(
    first: NDArray[np.int8], second: NDArray[np.int8], cells: NDArray[np.float64]
) -> int:
    """What :func:`tomosim.kernels.overlap.shared_free` counts, in array operations."""
    rows, cols = np.nonzero(free_mask(second))
    x = cells[0, 0] * cols + cells[0, 1] * rows + cells[0, 2]
    y = cells[1, 0] * cols + cells[1, 1] * rows + cells[1, 2]
    col, row = np.rint(x).astype(np.intp), np.rint(y).astype(np.intp)
    height, width = first.shape
    inside = (row >= 0) & (row < height) & (col >= 0) & (col < width)
    return int(np.count_nonzero(free_mask(first[row[inside], col[inside]])))


@dataclass(frozen=True, slots=True)
class PairQuality:
    """One pairwise estimate of a merge round against the truth.

    Attributes
    ----------
    first, second : int
        Robots ``i < j``; the transform takes ``second``'s map frame to ``first``'s.
    accepted : bool
        The merger vouched for the estimate.
    confirmed : bool
        Accepted in enough consecutive rounds with consistent estimates
        (:class:`~tomosim.team.merger.TeamMerger`); only confirmed estimates
        link maps.
    used : bool
        The estimate is an edge of the spanning forest that links the maps.
    confidence : float
        The merger's confidence in ``[0, 1]``.
    matching_index : float
        Eq. (31) of the paper: occupied cells shared after the estimated
        transform over the occupied cells of the overlap (0 when none); ``nan``
        for an estimate the merger did not accept (never used, and scoring it
        would cost a pass over the overlap per pair and round).
    estimate, truth : (float, float, float)
        Pose ``(x, y, yaw)`` of ``second``'s map frame in ``first``'s, metres
        and radians, as estimated and as true.
    rotation_error_deg, translation_error_m : float
        As in the module docstring (``inf`` without a finite estimate).
    reason : str
        Why the merger did not accept the estimate (empty when accepted).
    dropped : bool
        Confirmed, but left out of the links because it contradicts the others.
    shared_free_m2 : float
        Square metres of free space both grids know, laid by the true transform
        (:func:`shared_free_area`): how much the two maps overlap, whatever the
        estimate (``nan`` when not measured).
    """

    first: int
    second: int
    accepted: bool
    confirmed: bool
    used: bool
    confidence: float
    matching_index: float
    estimate: tuple[float, float, float]
    truth: tuple[float, float, float]
    rotation_error_deg: float
    translation_error_m: float
    reason: str = ""
    dropped: bool = False
    shared_free_m2: float = math.nan

    @property
    def name(self) -> str:
        """``"r0-r1"``: the pair's name in reports and recordings."""
        return pair_name(self.first, self.second)

    def as_dict(self) -> dict[str, Any]:
        """Plain values (for infos and JSON); non-finite numbers stay floats."""
        return {
            "accepted": self.accepted,
            "confirmed": self.confirmed,
            "used": self.used,
            "dropped": self.dropped,
            "confidence": self.confidence,
            "matching_index": self.matching_index,
            "rotation_error_deg": self.rotation_error_deg,
            "translation_error_m": self.translation_error_m,
            "estimate": self.estimate,
            "truth": self.truth,
            "reason": self.reason,
            "shared_free_m2": self.shared_free_m2,
        }


def pair_quality(
    outcome: PairOutcome,
    grids: tuple[OccupancyGrid, OccupancyGrid],
    starts: tuple[ArrayLike, ArrayLike],
) -> PairQuality:
    """Score one pair's estimate of a merge round against the truth.

    Parameters
    ----------
    outcome : PairOutcome
        The estimate for robots ``(i, j)``: its matrix takes grid ``j``'s cells
        to grid ``i``'s, and ``matrix_metres`` frame ``j`` to frame ``i``.
    grids : (OccupancyGrid, OccupancyGrid)
        Grids ``i`` and ``j`` as merged.
    starts : (array_like, array_like)
        True start poses of robots ``i`` and ``j``.
    """
    result = outcome.result
    truth = true_relative(*starts)
    metres = result.matrix_metres
    estimate = np.full((3, 3), np.nan) if metres is None else np.asarray(metres, dtype=np.float64)
    rotation, translation = frame_errors(estimate, truth)
    # The matching index costs a pass over the overlap: worth it for estimates that may
    # be used only.
    scored = result.accepted and bool(np.all(np.isfinite(result.matrix)))
    overlap = matching_index(grids[0].data, grids[1].data, result.matrix) if scored else np.nan
    pose = matrix_to_pose(estimate) if np.all(np.isfinite(estimate)) else (NO_ESTIMATE,) * 3
    return PairQuality(
        first=outcome.first,
        second=outcome.second,
        accepted=outcome.accepted,
        confirmed=outcome.confirmed,
        used=outcome.used,
        confidence=float(result.confidence),
        matching_index=float(overlap),
        estimate=_triple(pose),
        truth=_triple(matrix_to_pose(truth)),
        rotation_error_deg=rotation,
        translation_error_m=translation,
        reason=result.reason,
        dropped=outcome.dropped,
        shared_free_m2=shared_free_area(grids[0], grids[1], in_cells(*grids, truth)),
    )


@dataclass(frozen=True, slots=True)
class RoundQuality:
    """A merge round and how right it is: what reports, infos and recordings show.

    Attributes
    ----------
    merge : TeamMerge
        The round, as the merger made it from the grids alone.
    pairs : tuple of PairQuality
        Every pair of :attr:`TeamMerge.pairs`, scored against the truth.
    agreement : float
        :func:`merged_agreement` of the merged map with the ground truth.
    """

    merge: TeamMerge
    pairs: tuple[PairQuality, ...]
    agreement: float

    @property
    def step(self) -> int:
        """Simulation step after which the round ran."""
        return self.merge.step

    @property
    def method(self) -> str:
        """The merging method."""
        return self.merge.method

    @property
    def merged_robots(self) -> tuple[int, ...]:
        """Robots whose maps are fused into the merged map."""
        return self.merge.merged_robots

    @property
    def accepted(self) -> tuple[PairQuality, ...]:
        """The pairs whose estimate the merger accepted this round."""
        return tuple(p for p in self.pairs if p.accepted)

    def as_dict(self, *, name: Callable[[int], str] = robot_name) -> dict[str, Any]:
        """Plain values (for infos and JSON); ``name`` names robot ``k`` (default ``"r0"``),
        and a pair ``"{name(i)}-{name(j)}"``."""
        return {
            "step": self.step,
            "method": self.method,
            "agreement": self.agreement,
            "accepted": len(self.accepted),
            "merged_robots": [name(k) for k in self.merged_robots],
            "pairs": {f"{name(p.first)}-{name(p.second)}": p.as_dict() for p in self.pairs},
        }


def score_round(
    merge: TeamMerge, grids: Sequence[OccupancyGrid], starts: ArrayLike, truth: OccupancyGrid
) -> RoundQuality:
    """Score a merge round against the truth.

    Parameters
    ----------
    merge : TeamMerge
        The round.
    grids : sequence of OccupancyGrid
        The robots' grids the round merged, robot order.
    starts : (N, 3) array_like
        True start poses.
    truth : OccupancyGrid
        The world's ground-truth grid.
    """
    poses = np.asarray(starts, dtype=float)
    if poses.shape != (len(grids), 3):
        raise ValueError(
            f"starts must have shape ({len(grids)}, 3) (one pose per grid), got {poses.shape}"
        )
    pairs = tuple(
        pair_quality(p, (grids[p.first], grids[p.second]), (poses[p.first], poses[p.second]))
        for p in merge.pairs
    )
    agreement = merged_agreement(merge.merged, truth, poses[merge.reference])
    return RoundQuality(merge, pairs, float(agreement))


def merged_agreement(
    merged: OccupancyGrid, truth: OccupancyGrid, reference_start: ArrayLike
) -> float:
    """Acceptance index of the merged map against the ground truth.

    The merged map is placed in the world by the true start pose of the robot
    whose frame it is in, then compared cell by cell with the truth grid
    (:func:`merging.acceptance_index`: over the cells both know, the fraction
    that agree on occupied/free). 1 means no wall where the truth is free and
    no free cell where the truth has a wall; 0 without overlap.
    """
    into_truth = (
        np.linalg.inv(truth.cell_to_world_matrix())
        @ pose_matrix(reference_start)
        @ merged.cell_to_world_matrix()
    )
    rows, cols = merged.shape
    corners = np.array(
        [[-0.5, -0.5, 1], [cols - 0.5, -0.5, 1], [-0.5, rows - 0.5, 1], [cols - 0.5, rows - 0.5, 1]]
    )
    moved = (corners @ into_truth.T)[:, :2]
    low = np.floor(moved.min(axis=0)).astype(int) - TRUTH_WINDOW_MARGIN
    high = np.ceil(moved.max(axis=0)).astype(int) + TRUTH_WINDOW_MARGIN
    truth_rows, truth_cols = truth.shape
    x0, y0 = max(int(low[0]), 0), max(int(low[1]), 0)
    x1, y1 = min(int(high[0]), truth_cols - 1), min(int(high[1]), truth_rows - 1)
    if x0 > x1 or y0 > y1:
        return 0.0
    window = truth.data[y0 : y1 + 1, x0 : x1 + 1]
    shift = np.array([[1.0, 0.0, -x0], [0.0, 1.0, -y0], [0.0, 0.0, 1.0]])
    return acceptance_index(window, merged.data, shift @ into_truth)
