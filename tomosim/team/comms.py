"""Who can talk to whom: a communication range, optionally blocked by walls, and relays.

Two robots are *in range* when their true positions are at most ``range``
metres apart and, with ``line_of_sight``, no wall crosses the straight line
between them (the radio is the simulator's business, so it uses the true
positions, which the robots themselves never see). Messages are relayed:
robots *reach* each other when a chain of robots in range joins them, i.e.
when they are in the same connected component of the range graph
(:func:`reach_groups`).

The session (:class:`~tomosim.team.TeamSession`) recomputes the components
after every step. With them:

* a merge round estimates only pairs that reach each other at the step it
  runs; the others are refused unseen (:func:`out_of_reach`);
* robots exchange maps, poses and targets at every step, and only with the
  robots they reach then; what a robot received earlier it keeps
  (:class:`~tomosim.team.sharing.SharedMaps`).

Without a range (the default) every robot reaches every other at every step.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components

from merging.result import MergeResult
from merging.validators import boolean, real_number

CROSSING_TOLERANCE = 1e-12
"""Square metres: cross products smaller than this count as zero, so that a wall
parallel to a sight line (along it, or along its line) does not block it."""


@dataclass(frozen=True)
class CommsConfig:
    """How far robots can talk.

    Attributes
    ----------
    range : float or None
        Metres between two robots in range; None: unlimited (everyone reaches
        everyone).
    line_of_sight : bool
        Whether walls block a link (only with a range).
    """

    range: float | None = None
    line_of_sight: bool = False

    def __post_init__(self) -> None:
        if self.range is not None:
            real_number(
                self.range, "the communication range", low=0.0, low_open=True, unit="metres"
            )
        boolean(self.line_of_sight, "line_of_sight")
        if self.line_of_sight and self.range is None:
            raise ValueError("line of sight needs a communication range")

    @property
    def unlimited(self) -> bool:
        """Whether every robot always reaches every other."""
        return self.range is None


def blocked(starts: ArrayLike, ends: ArrayLike, walls: ArrayLike) -> NDArray[np.bool_]:
    """Which of the ``(M, 2)`` segments ``starts[m] -> ends[m]`` cross one of ``walls``.

    Parameters
    ----------
    starts, ends : (M, 2) array_like
        Metres.
    walls : (S, 2, 2) array_like
        Wall segments ``[[x0, y0], [x1, y1]]``, metres.

    Returns
    -------
    (M,) bool ndarray
        True where a wall crosses the segment strictly between its end points:
        a robot standing on a wall is not cut off by it, but a sight line
        through a wall's end point is blocked (two walls meeting at a corner let
        nothing through it); a parallel wall never blocks
        (:data:`CROSSING_TOLERANCE`).
    """
    p = np.asarray(starts, dtype=float).reshape(-1, 1, 2)
    r = np.asarray(ends, dtype=float).reshape(-1, 1, 2) - p
    segments = np.asarray(walls, dtype=float).reshape(-1, 2, 2)
    if len(segments) == 0 or p.shape[0] == 0:
        return np.zeros(p.shape[0], dtype=bool)
    q = segments[None, :, 0]
    s = segments[None, :, 1] - segments[None, :, 0]
    denominator = r[..., 0] * s[..., 1] - r[..., 1] * s[..., 0]
    qp = q - p
    t_num = qp[..., 0] * s[..., 1] - qp[..., 1] * s[..., 0]
    u_num = qp[..., 0] * r[..., 1] - qp[..., 1] * r[..., 0]
    crossing = np.abs(denominator) > CROSSING_TOLERANCE
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(crossing, t_num / denominator, -1.0)
        u = np.where(crossing, u_num / denominator, -1.0)
    inside = (t > 0.0) & (t < 1.0) & (u >= 0.0) & (u <= 1.0)
    return np.asarray(np.any(inside, axis=1))


def in_range(
    positions: ArrayLike, config: CommsConfig, walls: ArrayLike | None = None
) -> NDArray[np.bool_]:
    """``(N, N)`` symmetric mask of the pairs of robots in range (each robot with itself).

    Parameters
    ----------
    positions : (N, 2) array_like
        True positions, metres.
    config : CommsConfig
        The range and whether walls block it.
    walls : (S, 2, 2) array_like, optional
        The world's walls (needed for ``line_of_sight``).
    """
    where = np.asarray(positions, dtype=float).reshape(-1, 2)
    count = len(where)
    if config.range is None:
        return np.ones((count, count), dtype=bool)
    distance = np.hypot(*(where[:, None, :] - where[None, :, :]).transpose(2, 0, 1))
    linked = distance <= config.range
    if config.line_of_sight:
        if walls is None:
            raise ValueError("line of sight needs the world's walls")
        i, j = np.nonzero(np.triu(linked, k=1))
        cut = blocked(where[i], where[j], walls)
        linked[i[cut], j[cut]] = linked[j[cut], i[cut]] = False
    np.fill_diagonal(linked, True)
    return linked


def reach_groups(linked: NDArray[np.bool_]) -> NDArray[np.intp]:
    """Per robot, the label of its connected component of the range graph ``linked``:
    robots reach each other, through relays, when their labels are equal."""
    _, labels = connected_components(csr_matrix(linked), directed=False)
    return np.asarray(labels, dtype=np.intp)


def out_of_reach(i: int, j: int, method: str) -> MergeResult:
    """The result of a pair a merge round could not estimate: the robots could not talk."""
    return MergeResult(
        matrix=np.eye(3),
        confidence=0.0,
        accepted=False,
        method=method,
        reason=f"robots {i} and {j} are out of communication reach",
    )
