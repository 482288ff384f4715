"""Whether a placement is pinned down: what moving it a little would cost.

The constraint strength of :func:`merging.evidence.refine.constraint_strength` is the
curvature of the wall-to-wall attraction at the placement, on a field one
cell wide. Two maps that share only a small part of their area (3-15 %)
often meet at a corridor and a short cross wall or a door: the curvature
is weak, yet moving map 2 by a couple of cells along the corridor takes the
cross wall off its twin and lays map 2's open doorway on map 1's wall. That
is evidence of a different kind, ray consistency: a placement moved off the
truth lays walls on space the other robot saw free and free space on walls.

:func:`pinning` measures it directly for sliding. It moves the placement by
a few cells in several directions (``pin_directions``), verifies each moved placement both ways
(:func:`merging.evidence.verify.verify`: agreeing walls minus conflicting ones, each
map's walls on the other's clear free space), and returns the smallest loss
of net evidence, in cells. A placement that a corridor lets slide loses
nothing; one held by a corner loses the cross wall's cells in both maps;
one that is itself off the truth gains by moving towards it, so its
smallest loss is negative.

Turning is left to the curvature (:func:`merging.evidence.refine.turning_strength`):
a small overlap lets map 2 turn about it, and a turn that moves map 2's far
walls by two cells moves the overlap's own walls by a fraction of a cell,
which counting cells within one of a wall cannot see. How far out map 2's
walls reach from the overlap is :func:`lever_arm`: a turn too small for the
refinement to resolve at the overlap moves them that many times as much.
Where the curvature is flat the refinement is asked directly: restarted from
the placement turned a little either way, does it come back
(:func:`merging.evidence.verdict.turn_is_held`)? The same is asked of a
slide that costs too little to count (:func:`merging.evidence.verdict.slide_is_held`):
restarted from each of the moves :func:`pinning` tries (:func:`slides`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from merging.evidence.verify import DEFAULT_CONFIDENCE, DEFAULT_VERIFY, PreparedMap, verify
from merging.params import ConfidenceParams, VerifyParams
from merging.transforms import apply_transform, rigid_matrix


def pinning(
    first: PreparedMap,
    second: PreparedMap,
    matrix: NDArray[np.float64],
    *,
    params: ConfidenceParams = DEFAULT_CONFIDENCE,
    verify_params: VerifyParams = DEFAULT_VERIFY,
) -> float:
    """The least net evidence, in cells, lost by sliding ``matrix`` a little.

    Parameters
    ----------
    first, second : PreparedMap
        Map 1 and map 2.
    matrix : (3, 3) float ndarray
        The placement, map 2 cells -> map 1 cells.
    params : ConfidenceParams
        ``pin_cells``: the distances moved (cells, chessboard);
        ``pin_directions``: in how many directions.
    verify_params : VerifyParams
        The weights of the verification.

    Returns
    -------
    float
        ``min(net(matrix) - net(moved))`` over the moved placements, where
        ``net`` is :attr:`merging.evidence.verify.Verification.net` (agreeing wall
        cells minus ``conflict_weight`` times conflicting ones, both ways).
        Negative when a moved placement explains more.
    """
    base = verify(first, second, matrix, params=verify_params).net
    least = np.inf
    for move in slides(params):
        moved = verify(first, second, move @ matrix, params=verify_params).net
        least = min(least, base - moved)
    return float(least)


def slides(params: ConfidenceParams = DEFAULT_CONFIDENCE) -> list[NDArray[np.float64]]:
    """The small moves :func:`pinning` tries: ``pin_cells`` (chessboard) in each of
    ``pin_directions`` directions, as translations in map 1's cells, nearest first."""
    angles = np.arange(params.pin_directions) * (2.0 * np.pi / params.pin_directions)
    moves = []
    for distance in params.pin_cells:
        for angle in angles:
            step = np.array([np.cos(angle), np.sin(angle)])
            step *= distance / np.max(np.abs(step))
            moves.append(rigid_matrix(float(step[0]), float(step[1]), 0.0))
    return moves


def lever_arm(first: PreparedMap, second: PreparedMap, matrix: NDArray[np.float64]) -> float:
    """How many times farther map 2's walls lie from the overlap than the overlap's own.

    The RMS distance of all of map 2's wall cells, placed by ``matrix`` (map 2
    cells -> map 1 cells), from the centroid of those that meet map 1's walls
    (within the verification's near radius), over the RMS distance of those
    meeting ones from it. A turn about the overlap moves map 2's walls this
    many times as far as the overlap's own: 1 to 2 for maps that share most
    of their area, 3 to 10 for window pairs sharing 3-15 %.

    Returns
    -------
    float
        The ratio; ``inf`` when fewer than three walls meet or they meet at
        one point.
    """
    landed = apply_transform(matrix, second.points)
    meeting = meeting_walls(first, landed)
    if meeting.sum() < 3:
        return float("inf")
    centre = landed[meeting].mean(axis=0)
    own = float(np.sqrt(np.mean(np.sum((landed[meeting] - centre) ** 2, axis=1))))
    if own <= 0.0:
        return float("inf")
    return float(np.sqrt(np.mean(np.sum((landed - centre) ** 2, axis=1)))) / own


def meeting_walls(first: PreparedMap, landed: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Which of map 2's wall cells, placed at ``landed`` ((N, 2) float array of map 1's
    ``(x, y)`` cells), lie within the verification's near radius of map 1's walls."""
    cells = np.rint(landed).astype(np.intp)
    rows, cols = first.shape
    inside = (cells[:, 0] >= 0) & (cells[:, 1] >= 0) & (cells[:, 0] < cols) & (cells[:, 1] < rows)
    meeting = np.zeros(len(cells), dtype=bool)
    meeting[inside] = first.near_occupied[cells[inside, 1], cells[inside, 0]]
    return meeting
