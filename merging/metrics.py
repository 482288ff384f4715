"""How good a merge is: the paper's matching index, the acceptance index, error to truth."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from merging.grid import free_mask, occupied_cells, occupied_mask, validate_cells
from merging.transforms import apply_transform, matrix_to_pose, wrap_angle
from merging.warp import warp_cells


def matching_index(map1: ArrayLike, map2: ArrayLike, matrix: ArrayLike) -> float:
    """The matching index Ψ of eq. (31) of the paper.

    Map 2 is carried into map 1's grid with ``matrix``; the index is the
    number of cells occupied in both, divided by ``N_overlap``, the number of
    occupied cells in the overlapping area. The paper leaves open whose
    occupied cells ``N_overlap`` counts; we count the cells occupied in
    *either* map within the area both maps know (so a merge that lays walls
    beside walls is not rewarded), which makes Ψ = 1 exactly for a perfect
    overlap of identical maps and lower for every misalignment.

    Returns 0 when the maps do not overlap.
    """
    return _matching(*_warped(map1, map2, matrix))


def _warped(
    map1: ArrayLike, map2: ArrayLike, matrix: ArrayLike
) -> tuple[NDArray[np.int8], NDArray[np.int8]]:
    """Map 1's cells and map 2's carried into map 1's grid with ``matrix``."""
    cells1 = validate_cells(np.asarray(map1), name="map1")
    cells2 = validate_cells(np.asarray(map2), name="map2")
    return cells1, warp_cells(cells2, np.asarray(matrix, dtype=float), cells1.shape)


def _matching(cells1: NDArray[np.int8], warped: NDArray[np.int8]) -> float:
    overlap = (cells1 >= 0) & (warped >= 0)
    occ1 = occupied_mask(cells1) & overlap
    occ2 = occupied_mask(warped) & overlap
    n_overlap = int(np.count_nonzero(occ1 | occ2))
    if n_overlap == 0:
        return 0.0
    return float(np.count_nonzero(occ1 & occ2)) / n_overlap


def acceptance_index(map1: ArrayLike, map2: ArrayLike, matrix: ArrayLike) -> float:
    """Birk and Carpin's acceptance index ω = agr / (agr + dis).

    Over the cells both maps know after carrying map 2 into map 1's grid,
    ``agr`` counts cells that are occupied in both or free in both, ``dis``
    cells occupied in one and free in the other. Returns 0 without overlap.

    References
    ----------
    A. Birk and S. Carpin, "Merging occupancy grid maps from multiple robots",
    Proc. IEEE 94(7), 2006.
    """
    return _acceptance(*_warped(map1, map2, matrix))


def _acceptance(cells1: NDArray[np.int8], warped: NDArray[np.int8]) -> float:
    occ1, occ2 = occupied_mask(cells1), occupied_mask(warped)
    free1, free2 = free_mask(cells1), free_mask(warped)
    agree = np.count_nonzero((occ1 & occ2) | (free1 & free2))
    disagree = np.count_nonzero((occ1 & free2) | (free1 & occ2))
    total = agree + disagree
    return float(agree) / total if total else 0.0


def match_indices(map1: ArrayLike, map2: ArrayLike, matrix: ArrayLike) -> tuple[float, float]:
    """``(matching_index, acceptance_index)`` of one transform, warping map 2 once.

    The same values as :func:`matching_index` and :func:`acceptance_index`, at
    half the cost when both are wanted (benchmarks score every method's
    answer with both).
    """
    cells1, warped = _warped(map1, map2, matrix)
    return _matching(cells1, warped), _acceptance(cells1, warped)


def transform_error(estimate: ArrayLike, truth: ArrayLike, map2: ArrayLike) -> tuple[float, float]:
    """Error of an estimated transform against the truth, on map 2's occupied cells.

    Returns
    -------
    rms_cells : float
        Root-mean-square distance, in cells, between where ``estimate`` and
        ``truth`` put map 2's occupied cells (its bounding-box corners when it
        has none).
    rotation_deg : float
        Absolute rotation difference in degrees, in ``[0, 180]``.
    """
    cells2 = validate_cells(np.asarray(map2), name="map2")
    points = occupied_cells(cells2)
    if len(points) == 0:
        rows, cols = cells2.shape
        points = np.array([[0, 0], [cols - 1, 0], [0, rows - 1], [cols - 1, rows - 1]], float)
    diff = apply_transform(estimate, points) - apply_transform(truth, points)
    rms = float(np.sqrt(np.mean(np.sum(diff**2, axis=1))))
    rotation = abs(float(wrap_angle(matrix_to_pose(estimate)[2] - matrix_to_pose(truth)[2])))
    return rms, float(np.degrees(rotation))


def as_matrix(values: ArrayLike) -> NDArray[np.float64]:
    """Check and return a 3x3 float matrix."""
    m = np.asarray(values, dtype=float)
    if m.shape != (3, 3) or not np.all(np.isfinite(m)):
        raise ValueError(f"matrix must be a finite 3x3 array, got shape {m.shape}")
    return m
