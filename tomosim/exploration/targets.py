"""What choosing a frontier works with: the candidates, what a robot knows of its team.

A robot that replans has, on its best map, the frontier clusters it can
reach (:class:`Candidate`: their cells, where they are and what reaching
each cell costs) and what it knows of the teammates it is linked to and can
talk to (:class:`Teammate`: where each is and the frontier it is driving to,
carried into the robot's frame by the merge transform, and the cost of its
paths). A *target chooser* (:class:`TargetChooser`) turns these into one
target cell; the choosers and their registry are in
:mod:`~tomosim.exploration.choosers`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

PathCosts = Callable[[NDArray[np.float64]], NDArray[np.float64]]
"""``costs(points)``: metres of path from a teammate to ``(K, 2)`` points (metres, in the
asking robot's frame); ``inf`` where the teammate knows no path."""


@dataclass(frozen=True, slots=True)
class Candidate:
    """A frontier cluster the robot can reach.

    Attributes
    ----------
    cells : (K, 2) int ndarray
        ``(x, y) = (col, row)`` of its reachable cells in the planning grid.
    points : (K, 2) float ndarray
        Their centres in metres, in the robot's frame.
    costs : (K,) float ndarray
        Metres of path from the robot to each (finite).
    length : float
        Metres of frontier in the whole cluster (its cells times the cell size).
    """

    cells: NDArray[np.intp]
    points: NDArray[np.float64]
    costs: NDArray[np.float64]
    length: float


@dataclass(frozen=True, slots=True)
class Teammate:
    """What a robot knows of one teammate, in its own frame (metres).

    Attributes
    ----------
    robot : int
        The teammate's index.
    position : (2,) float ndarray
        Where the teammate's pose estimate puts it.
    target : (2,) float ndarray or None
        The frontier cell it drives to (None: it has none).
    path_costs : PathCosts or None
        Its path costs to points, from its latest plan (None: not known).
    """

    robot: int
    position: NDArray[np.float64]
    target: NDArray[np.float64] | None = None
    path_costs: PathCosts | None = None


Choice = tuple[int, int]
"""``(candidate index, cell index within the candidate)``."""


class TargetChooser(Protocol):
    """Chooses a target among a robot's candidates.

    ``coordinated`` says whether it uses teammates at all: a coordinated
    robot also gives up a target a teammate nearer to it has taken
    (:meth:`FrontierPolicy.act <tomosim.exploration.FrontierPolicy.act>`).
    """

    @property
    def name(self) -> str:
        """The chooser's name in :data:`CHOOSERS`."""
        ...

    @property
    def coordinated(self) -> bool:
        """Whether it uses teammates."""
        ...

    def choose(
        self, candidates: Sequence[Candidate], teammates: Sequence[Teammate], *, size_bonus: float
    ) -> Choice | None:
        """The target among ``candidates`` (None when there are none).

        ``size_bonus`` is the metres of path one metre of a cluster's frontier
        is worth (:class:`~tomosim.exploration.ExplorationConfig`).
        """
        ...


def own_scores(candidate: Candidate, size_bonus: float) -> NDArray[np.float64]:
    """Per cell: metres of path to it less the size bonus of its cluster (lower is better)."""
    return candidate.costs - size_bonus * candidate.length
