"""Robots to frontier clusters by path cost: the Hungarian method.

A robot that replans builds the cost matrix of the robots it knows of
(itself and its linked teammates) against the frontier clusters of its own
best map, and solves the assignment of least total cost
(:func:`scipy.optimize.linear_sum_assignment`); it then drives to the cluster
it was assigned. Decentralised like :mod:`~tomosim.exploration.utility`:

1. **Its own costs**: per cluster, the cheapest cell's path cost from its
   wavefront.
2. **Teammates' costs**: per cluster, the cheapest cell's cost on the
   teammate's own latest wavefront (:attr:`Teammate.path_costs`, carried
   through the merge transform); where the teammate knows no path there,
   the straight-line distance times :attr:`AssignmentChooser.detour_factor`.
3. **Commitments**: a teammate already driving to a target keeps it: its row
   costs nothing at the cluster holding its target (within
   :attr:`AssignmentChooser.claim_radius`) and :data:`UNAVAILABLE_COST_M` elsewhere; a
   teammate whose target is on none of the robot's clusters is busy
   elsewhere and left out.
4. Every cost is less the cluster's size bonus (the same for every robot,
   it decides which clusters are worth a robot when there are more clusters
   than robots).
5. A robot assigned no cluster (more robots than clusters) takes its
   cheapest one, as alone.

Alone, the matrix has one row and the assignment is the nearest chooser's.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import linear_sum_assignment

from merging.validators import real_number
from tomosim.exploration.targets import Candidate, Choice, Teammate, own_scores

UNAVAILABLE_COST_M = 1.0e6
"""Metres: the cost of an assignment that cannot be (a committed teammate elsewhere);
finite, as linear_sum_assignment needs, and larger than any path."""


def teammate_costs(
    candidates: Sequence[Candidate], mate: Teammate, *, detour_factor: float
) -> NDArray[np.float64]:
    """Step 2: a teammate's cost of each cluster (metres); ``detour_factor`` path metres per
    straight-line metre where its plan knows no path."""
    out = np.empty(len(candidates))
    for k, candidate in enumerate(candidates):
        planned = (
            mate.path_costs(candidate.points)
            if mate.path_costs is not None
            else np.full(len(candidate.points), np.inf)
        )
        straight = detour_factor * np.hypot(*(candidate.points - mate.position).T)
        out[k] = float(np.min(np.where(np.isfinite(planned), planned, straight)))
    return out


def claimed_cluster(
    candidates: Sequence[Candidate], target: NDArray[np.float64], *, radius: float
) -> int | None:
    """Step 3: the cluster with a cell nearest ``target``, if within ``radius`` metres."""
    best: tuple[float, int] | None = None
    for k, candidate in enumerate(candidates):
        distance = float(np.min(np.hypot(*(candidate.points - target).T)))
        if distance <= radius and (best is None or distance < best[0]):
            best = (distance, k)
    return None if best is None else best[1]


@dataclass(frozen=True, slots=True)
class AssignmentChooser:
    """The target of the module docstring's assignment.

    Attributes
    ----------
    claim_radius : float
        Metres: a teammate's target this close to a cluster's cell claims the
        cluster (step 3). The same frontier seen on two robots' maps lies a
        few cells apart (drift, merge error, maps a refresh apart); clusters
        of different openings are further apart than a doorway.
    detour_factor : float
        Path metres per straight-line metre assumed where a teammate's own
        plan knows no path to a cluster (step 2; indoor paths run about a
        third longer than the straight line).
    name, coordinated
        The chooser's name, and that it uses what it knows of teammates.
    """

    claim_radius: float = 1.0
    detour_factor: float = 1.5
    name: str = "assignment"
    coordinated: bool = True

    def __post_init__(self) -> None:
        real_number(self.claim_radius, "claim_radius", low=0.0, unit="metres")
        real_number(self.detour_factor, "detour_factor", low=1.0)

    def choose(
        self, candidates: Sequence[Candidate], teammates: Sequence[Teammate], *, size_bonus: float
    ) -> Choice | None:
        if not candidates:
            return None
        bonus = np.array([size_bonus * c.length for c in candidates])
        own = np.array([float(np.min(c.costs)) for c in candidates])
        rows = [own - bonus]
        for mate in teammates:
            if mate.target is None:
                costs = teammate_costs(candidates, mate, detour_factor=self.detour_factor)
                rows.append(costs - bonus)
                continue
            claimed = claimed_cluster(candidates, mate.target, radius=self.claim_radius)
            if claimed is None:
                continue  # busy on a frontier this robot does not see
            row = np.full(len(candidates), UNAVAILABLE_COST_M)
            row[claimed] = -bonus[claimed]
            rows.append(row)
        robots, clusters = linear_sum_assignment(np.vstack(rows))
        mine = clusters[robots == 0]
        k = int(mine[0]) if len(mine) else int(np.argmin(rows[0]))
        scores = own_scores(candidates[k], size_bonus)
        return k, int(np.argmin(scores))
