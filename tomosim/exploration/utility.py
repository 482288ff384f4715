"""Burgard et al.'s coordination: a frontier is worth less near targets teammates have taken.

In [1]_ every frontier cell ``t`` starts with utility ``U_t = 1``; once a
robot is sent to target ``t'``, the utility of every cell near it falls by the
probability that it will be seen from there::

    U_t <- U_t - P(|t - t'|),    P(d) = 1 - d / R  for d < R, else 0,

with ``R`` the sensor's reach, and the next robot takes the cell maximising
``U_t - beta V_t``, its utility less ``beta`` times its path cost ``V_t``.

Here each robot chooses for itself from what it knows (decentralised, as a
robot whose teammates announce their targets does; in a step robots replan in
index order, so a robot sees the targets chosen before it in the same step,
which is the paper's sequential assignment). With costs in metres the
choice is the cell minimising

    V_t - size bonus - w U_t,

where ``w`` (:attr:`UtilityChooser.weight`) is the metres of path a fresh
target is worth (``1 / beta`` in the paper's terms) and the size bonus is the
one every chooser gives a cluster (:mod:`~tomosim.exploration.targets`).
Alone, ``U_t = 1`` everywhere and the choice is the nearest chooser's.

References
----------
.. [1] W. Burgard, M. Moors, C. Stachniss, F. E. Schneider, "Coordinated
   multi-robot exploration", IEEE Transactions on Robotics 21(3), 376-386,
   2005, section IV (the utility update and Table I).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from merging.validators import real_number
from tomosim.exploration.targets import Candidate, Choice, Teammate, own_scores


def visibility(distance: ArrayLike, radius: float) -> NDArray[np.float64]:
    """``P(d) = max(0, 1 - d / R)``: the chance a cell ``d`` metres from a target is seen
    from there (eq. of section IV of [1], with ``R = radius``)."""
    d = np.asarray(distance, dtype=float)
    return np.clip(1.0 - d / radius, 0.0, None)


def utilities(
    points: NDArray[np.float64], targets: Sequence[NDArray[np.float64]], radius: float
) -> NDArray[np.float64]:
    """``U_t`` of each ``(K, 2)`` point after the teammates' ``targets`` were assigned.

    Starts at 1 and falls by :func:`visibility` for every target (it may fall
    below 0 near several, as in the paper).
    """
    utility = np.ones(len(points))
    for target in targets:
        utility -= visibility(np.hypot(*(points - target).T), radius)
    return utility


@dataclass(frozen=True, slots=True)
class UtilityChooser:
    """The target of module docstring's rule.

    Attributes
    ----------
    weight : float
        Metres of path a fresh target (utility 1) is worth: a cell at a
        teammate's target (utility 0) loses to any other frontier up to 12 m
        further away, about the width of two rooms of a generated floor, so
        robots split across neighbouring rooms rather than follow each other;
        further frontiers are left to the teammate. Set by that reasoning, not
        tuned; ``scripts/study_exploration.py`` measures the policy with it.
    radius : float
        Metres: ``R`` of the visibility probability ``P(d)``
        (:func:`visibility`). The paper takes the sensor's range; indoors
        walls hide most of an 8 m lidar's reach, and a smaller radius keeps
        frontiers of the next room, which a teammate's target does not show,
        at full worth.
    name, coordinated
        The chooser's name, and that it uses what it knows of teammates.
    """

    weight: float = 12.0
    radius: float = 6.0
    name: str = "utility"
    coordinated: bool = True

    def __post_init__(self) -> None:
        real_number(self.weight, "weight", low=0.0, unit="metres")
        real_number(self.radius, "radius", low=0.0, low_open=True, unit="metres")

    def choose(
        self, candidates: Sequence[Candidate], teammates: Sequence[Teammate], *, size_bonus: float
    ) -> Choice | None:
        targets = [mate.target for mate in teammates if mate.target is not None]
        best: tuple[float, Choice] | None = None
        for k, candidate in enumerate(candidates):
            scores = own_scores(candidate, size_bonus)
            if targets:
                scores = scores - self.weight * utilities(candidate.points, targets, self.radius)
            index = int(np.argmin(scores))
            if best is None or scores[index] < best[0]:
                best = (float(scores[index]), (k, index))
        return None if best is None else best[1]
