"""The known-poses bound: merging with the true relative start poses.

``method="oracle"`` stands for a merger that is always right: for every pair
of robots, every round, it returns the true transform between their map
frames, accepted with confidence 1, whatever the maps hold (with known start
poses robots need no overlap to share maps). No merger working from the grids
can link maps sooner or more accurately, so the time an oracle team takes to
explore is the bound a merger is measured against; merging off is the other
bound.

The oracle is a :data:`~tomosim.team.merger.PairEstimator` plugged into the
same :class:`~tomosim.team.merger.TeamMerger` (same rounds, same
confirmation rule, same linking and sharing), so that a comparison with the
tomographic merger isolates the estimates. It is built by the session, the
one place that holds the true start poses; :mod:`merging` never sees them.

With ``min_shared_m2`` the oracle needs overlap as a merger working from the
grids does: it answers a pair only once the two maps share that much free
space under the true transform
(:func:`~tomosim.team.quality.shared_free_area`), and refuses it before. Its
time to explore, beside the plain oracle's, is what linking only once the maps
overlap costs a team, whatever merger does the linking.

The transform taking robot ``j``'s map frame to robot ``i``'s is
``inv(P_i) @ P_j`` (:func:`~tomosim.team.quality.true_relative`), in metres;
in cells, ``inv(C_i) @ inv(P_i) @ P_j @ C_j`` with ``C_k`` the matrix taking
grid ``k``'s cells to its frame (:meth:`OccupancyGrid.cell_to_world_matrix`).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from merging import available_methods
from merging.grid import OccupancyGrid
from merging.result import MergeResult
from merging.validators import one_of, real_number
from tomosim.frames import pose_matrix
from tomosim.team.merger import PairEstimator
from tomosim.team.quality import in_cells, shared_free_area, true_relative

ORACLE = "oracle"
"""The method name of the known-poses bound."""


def team_methods() -> tuple[str, ...]:
    """Merging methods a team accepts: :func:`merging.available_methods` and :data:`ORACLE`."""
    return (*available_methods(), ORACLE)


def check_team_method(method: object) -> str:
    """Return ``method`` if a team can merge with it, else raise ValueError listing the names."""
    return one_of(method, team_methods(), what="merging method")


def oracle_estimator(
    starts: ArrayLike,
    *,
    error_deg: float = 0.0,
    error_m: float = 0.0,
    min_shared_m2: float = 0.0,
) -> PairEstimator:
    """A pair estimator returning the true transforms between the robots' map frames.

    Parameters
    ----------
    starts : (N, 3) array_like
        The robots' true start poses ``(x, y, theta)`` in the world.
    error_deg, error_m : float
        A fixed error per pair (:func:`pair_error`): the transform turned by
        ``error_deg`` degrees and robot ``j``'s start moved by ``error_m``
        metres (0, 0: the truth).
    min_shared_m2 : float
        Square metres of free space the two maps must share under the true
        transform (:func:`~tomosim.team.quality.shared_free_area`) before the
        oracle accepts the pair (0: always, whatever the maps hold). Above 0 every
        answer carries the area in ``evidence["shared_free_m2"]``.
    """
    poses = np.array(starts, dtype=float)
    if poses.ndim != 2 or poses.shape[1] != 3 or not np.all(np.isfinite(poses)):
        raise ValueError(f"starts must be a finite (N, 3) array of poses, got shape {poses.shape}")
    real_number(min_shared_m2, "min_shared_m2", low=0.0, unit="square metres")
    for value, name in ((error_deg, "error_deg"), (error_m, "error_m")):
        if not (np.isfinite(value) and value >= 0):
            raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")

    def estimate(i: int, j: int, grid_i: OccupancyGrid, grid_j: OccupancyGrid) -> MergeResult:
        if not (0 <= i < len(poses) and 0 <= j < len(poses)):
            raise ValueError(f"robots ({i}, {j}) out of range for {len(poses)} start poses")
        metres = true_relative(poses[i], poses[j])
        if error_deg or error_m:
            metres = metres @ pair_error(i, j, error_deg, error_m)
        answer = MergeResult(
            matrix=in_cells(grid_i, grid_j, metres),
            confidence=1.0,
            accepted=True,
            method=ORACLE,
            matrix_metres=np.asarray(metres, dtype=np.float64),
        )
        if min_shared_m2 <= 0:
            return answer
        truth = in_cells(grid_i, grid_j, true_relative(poses[i], poses[j]))
        shared = shared_free_area(grid_i, grid_j, truth)
        evidence = {"shared_free_m2": shared}
        if shared >= min_shared_m2:
            return replace(answer, evidence=evidence)
        reason = (
            f"the maps share {shared:.2f} m² of free space, less than the "
            f"{min_shared_m2:g} m² the oracle waits for"
        )
        return replace(answer, confidence=0.0, accepted=False, reason=reason, evidence=evidence)

    return estimate


def pair_error(i: int, j: int, error_deg: float, error_m: float) -> NDArray[np.float64]:
    """The fixed error of pair ``(i, j)``: a rigid matrix, in robot ``j``'s map frame, that
    turns by ``error_deg`` degrees (its sign) and shifts by ``error_m`` metres (its
    direction) drawn from a generator seeded with the pair, so a run repeats itself.

    Applied on the right of the true transform, it moves ``j``'s start ``error_m``
    metres from the truth and turns ``j``'s frame ``error_deg`` degrees
    (:func:`tomosim.frames.frame_errors` gives back exactly those).
    """
    draw = np.random.default_rng((int(i), int(j)))
    direction = float(draw.uniform(0.0, 2.0 * np.pi))
    sign = 1.0 if draw.random() < 0.5 else -1.0
    shift = (error_m * np.cos(direction), error_m * np.sin(direction))
    return pose_matrix((shift[0], shift[1], sign * np.radians(error_deg)))
