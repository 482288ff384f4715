"""Placing a group of grids by all of its pairwise transforms at once, not along a tree.

A spanning tree (:func:`merging.linking.forest.link_maps`) chains each grid to its
group's root through the most confident pairs; every other pair is left
unused. For grids drawn by separate sessions, which bend against each other by
up to half a metre, each link is right only to within that bending, and a
chain of several links adds their errors up: a grid five links from the root
can land farther off than any one pair. Using every pair at once spreads the
bending over the group instead, as a pose graph does for the scans of a
robot's path (F. Lu and E. Milios, "Globally consistent range scan alignment
for environment mapping", Autonomous Robots 4(4), 1997).

Each grid ``k`` gets a rigid pose ``T_k`` (its cells -> the root's cells; the
root's is the identity). A pair ``(i, j)`` with matrix ``M_ij`` (grid ``j``'s
cells -> grid ``i``'s) asks that grid ``j``'s wall cells ``p`` land where grid
``i``'s pose puts ``M_ij p``::

    E = Σ_(i, j)  mean_p | T_j p - T_i M_ij p |²

each pair weighing alike whatever its wall count. Gauss-Newton on the poses
``(x, y, θ)`` from the tree's solves it in a few steps.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from merging.transforms import apply_transform, matrix_to_pose, rigid_matrix

POINTS_PER_PAIR = 200
"""Wall cells of grid ``j`` sampled per pair (evenly along its list)."""
MAX_ITERATIONS = 30
"""Gauss-Newton steps at most."""
MAX_HALVINGS = 10
"""Times a step that does not lower the misfit is halved before the solve stops."""
CONVERGED = 1e-6
"""A step moving no pose by more than this (cells or radians) ends the solve."""


def adjust_poses(
    transforms: Sequence[NDArray[np.float64]],
    root: int,
    members: Sequence[int],
    pairs: Mapping[tuple[int, int], NDArray[np.float64]],
    points: Sequence[NDArray[np.float64]],
) -> list[NDArray[np.float64]]:
    """Poses of ``members`` that fit every pair among them, the root held fixed.

    Parameters
    ----------
    transforms : sequence of (3, 3) float ndarray
        Per grid, its cells -> its root's cells: the start (a tree's).
    root : int
        The grid whose frame the others are placed in; it does not move.
    members : sequence of int
        The grids of the root's group.
    pairs : mapping
        ``(i, j) -> M_ij`` (grid ``j``'s cells -> grid ``i``'s) for pairs of
        members; others are ignored.
    points : sequence of (N, 2) float ndarray
        Per grid, wall cells ``(x, y)`` to measure a pair's misfit on.

    Returns
    -------
    list of (3, 3) float ndarray
        ``transforms`` with the members' replaced (rigid).
    """
    group = set(members)
    edges = [(i, j, np.asarray(m, dtype=float)) for (i, j), m in pairs.items()
             if i in group and j in group]  # fmt: skip
    moving = [k for k in members if k != root]
    slot = {k: n for n, k in enumerate(moving)}
    poses = {k: np.array(matrix_to_pose(transforms[k])) for k in members}
    poses[root] = np.zeros(3)
    samples = []
    for i, j, matrix in edges:
        own = points[j]
        chosen = own[:: max(1, len(own) // POINTS_PER_PAIR)]
        samples.append((i, j, chosen, apply_transform(matrix, chosen)))
    size = 3 * len(moving)
    cost = _misfit(poses, samples)
    for _ in range(MAX_ITERATIONS):
        if size == 0:
            break
        normal = np.zeros((size, size))
        gradient = np.zeros(size)
        for i, j, own, carried in samples:
            placed_j, jac_j = _placed(poses[j], own)
            placed_i, jac_i = _placed(poses[i], carried)
            residual = placed_j - placed_i
            weight = 1.0 / len(own)
            for a, jac_a, sign_a in ((j, jac_j, 1.0), (i, jac_i, -1.0)):
                if a not in slot:
                    continue
                rows = slice(3 * slot[a], 3 * slot[a] + 3)
                gradient[rows] += weight * sign_a * np.einsum("nij,ni->j", jac_a, residual)
                for b, jac_b, sign_b in ((j, jac_j, 1.0), (i, jac_i, -1.0)):
                    if b in slot:
                        cols = slice(3 * slot[b], 3 * slot[b] + 3)
                        block = np.einsum("nij,nik->jk", jac_a, jac_b)
                        normal[rows, cols] += weight * sign_a * sign_b * block
        step = np.linalg.lstsq(normal, -gradient, rcond=None)[0]
        # Gauss-Newton's step, halved while it does not lower the misfit (the turn
        # makes the problem nonlinear): the result never fits worse than the start.
        for _ in range(MAX_HALVINGS):
            trial = {k: poses[k] + step[3 * n : 3 * n + 3] for k, n in slot.items()}
            trial[root] = poses[root]
            trial_cost = _misfit(trial, samples)
            if trial_cost <= cost:
                break
            step = step / 2.0
        else:
            break
        poses, cost = trial, trial_cost
        if np.abs(step).max() < CONVERGED:
            break
    adjusted = [np.asarray(t, dtype=np.float64) for t in transforms]
    for k in moving:
        adjusted[k] = rigid_matrix(*poses[k])
    return adjusted


def _misfit(
    poses: dict[int, NDArray[np.float64]],
    samples: list[tuple[int, int, NDArray[np.float64], NDArray[np.float64]]],
) -> float:
    """``E`` of the module docstring for ``poses``."""
    total = 0.0
    for i, j, own, carried in samples:
        residual = _placed(poses[j], own)[0] - _placed(poses[i], carried)[0]
        total += float(np.sum(residual**2)) / len(own)
    return total


def _placed(
    pose: NDArray[np.float64], cells: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``cells`` moved by ``pose = (x, y, θ)``, and the (N, 2, 3) Jacobian by the pose."""
    x, y, theta = pose
    c, s = np.cos(theta), np.sin(theta)
    u, v = cells[:, 0], cells[:, 1]
    placed = np.column_stack([c * u - s * v + x, s * u + c * v + y])
    jacobian = np.zeros((len(cells), 2, 3))
    jacobian[:, 0, 0] = 1.0
    jacobian[:, 1, 1] = 1.0
    jacobian[:, 0, 2] = -s * u - c * v
    jacobian[:, 1, 2] = c * u - s * v
    return placed, jacobian
