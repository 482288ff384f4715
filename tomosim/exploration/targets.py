"""Choosing a frontier to drive to: the candidates, what a robot knows of its team, the rules.

A robot that replans has, on its best map, the frontier clusters it can
reach (:class:`Candidate`: their cells, where they are and what reaching
each cell costs) and what it knows of the teammates it is linked to and can
talk to (:class:`Teammate`: where each is and the frontier it is driving to,
carried into the robot's frame by the merge transform, and the cost of its
paths). A *target chooser* turns these into one target cell.

Choosers are selected by name (:data:`CHOOSERS`, :func:`make_chooser`):

``nearest``
    The cheapest cluster to reach, less a bonus for its size; teammates are
    ignored (every robot explores as if alone).
``utility``
    Burgard et al.'s coordination [1]_ (:mod:`~tomosim.exploration.utility`):
    a frontier cell's utility drops around the targets teammates have taken.
``assignment``
    Robots to clusters by path cost, the Hungarian method
    (:mod:`~tomosim.exploration.assignment`).

Every chooser scores the same way when a robot is alone, so with no links
the three give the same episode.

References
----------
.. [1] W. Burgard, M. Moors, C. Stachniss, F. E. Schneider, "Coordinated
   multi-robot exploration", IEEE Transactions on Robotics 21(3), 376-386, 2005.
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


@dataclass(frozen=True, slots=True)
class NearestChooser:
    """The cheapest cell to reach, less its cluster's size bonus; teammates ignored."""

    name: str = "nearest"
    coordinated: bool = False

    def choose(
        self, candidates: Sequence[Candidate], teammates: Sequence[Teammate], *, size_bonus: float
    ) -> Choice | None:
        best: tuple[float, Choice] | None = None
        for k, candidate in enumerate(candidates):
            scores = own_scores(candidate, size_bonus)
            index = int(np.argmin(scores))
            if best is None or scores[index] < best[0]:
                best = (float(scores[index]), (k, index))
        return None if best is None else best[1]


def chooser_names() -> tuple[str, ...]:
    """Names :func:`make_chooser` accepts."""
    return tuple(CHOOSERS)


def make_chooser(name: str) -> TargetChooser:
    """The chooser called ``name``, with its default settings.

    Raises
    ------
    ValueError
        For an unknown name (the message lists the known ones).
    """
    factory = CHOOSERS.get(name)
    if factory is None:
        raise ValueError(
            f"unknown exploration policy {name!r}; choose one of: {', '.join(CHOOSERS)}"
        )
    return factory()


def _utility() -> TargetChooser:
    from tomosim.exploration.utility import UtilityChooser

    return UtilityChooser()


def _assignment() -> TargetChooser:
    from tomosim.exploration.assignment import AssignmentChooser

    return AssignmentChooser()


CHOOSERS: dict[str, Callable[[], TargetChooser]] = {
    "nearest": NearestChooser,
    "utility": _utility,
    "assignment": _assignment,
}
"""Every chooser by name."""
