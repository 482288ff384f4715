"""Second looks at a placement: the refinement restarted from it, moved a little.

Counting walls cell by cell cannot see everything that holds a placement,
so the verdict (:mod:`merging.tomographic.judging`) asks the refinement
itself:

* turned a little about the overlap, does it come back
  (:class:`TurnedRestarts`), or does it find an optimum of its own that
  explains about as much, a rival (:func:`turned_rival`, weighed by
  :func:`rival_factor`)?
* slid a little, does it come back (:func:`slide_return`)?
* refined the other way round, map 1 onto map 2, where does it land
  (:func:`both_ways`)?
* on fields as wide as the bending of two sessions' maps, where does the
  whole overlap pull it (:func:`rigid_compromise`)?
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.special import expit

from merging.evidence.pinning import meeting_walls, slides
from merging.evidence.refine import SmoothedMap
from merging.tomographic.candidates import Candidate, SearchMaps, refined_on, rms_between
from merging.transforms import (
    apply_transform,
    halfway,
    matrix_to_pose,
    rigid_matrix,
    translation_matrix,
    wrap_angle,
)


class TurnedRestarts:
    """The narrow refinement restarted from a placement turned a little about its overlap.

    A small overlap holds map 2's far walls by a lever: a turn moving them
    two cells moves the overlap's walls by a fraction of one, which counting
    walls cell by cell cannot see. Whether the overlap holds the turn is
    asked of the refinement itself: ``best`` is turned about the centroid
    of map 2's walls that meet map 1's, by the angles moving all of map 2's
    walls ``TomographicParams.near_rival_turns`` cells RMS either way, and
    each start is refined on the narrow fields to the optimum it leads to.
    Run once, when first asked, for both uses: the turn is held when every
    start comes back (:meth:`farthest`, :func:`merging.evidence.verdict.judge`),
    and an optimum of its own elsewhere is a rival (:func:`turned_rival`).
    """

    __slots__ = ("_found", "_maps", "best")

    def __init__(self, maps: SearchMaps, best: NDArray[np.float64]):
        self._maps, self.best = maps, best
        self._found: list[Candidate] | None = None

    def found(self) -> list[Candidate]:
        """The optimum each turned start led to (none when no walls meet)."""
        if self._found is None:
            self._found = self._restart()
        return self._found

    def farthest(self) -> float:
        """How far (cells RMS over map 2's walls) the farthest restart ended from ``best``;
        ``inf`` when no walls meet to turn about."""
        found = self.found()
        if not found:
            return float("inf")
        points = self._maps.second.points
        return max(rms_between(matrix, self.best, points) for _, matrix in found)

    def _restart(self) -> list[Candidate]:
        maps, best = self._maps, self.best
        params = maps.params
        landed = apply_transform(best, maps.second.points)
        meeting = meeting_walls(maps.first, landed)
        if not meeting.any():
            return []
        pivot = landed[meeting].mean(axis=0)
        radius = float(np.sqrt(np.mean(np.sum((landed - pivot) ** 2, axis=1))))
        if radius <= 0.0:
            return []
        found: list[Candidate] = []
        for moved in params.near_rival_turns:
            for sign in (-1.0, 1.0):
                turn = (
                    translation_matrix(pivot)
                    @ rigid_matrix(0.0, 0.0, sign * moved / radius)
                    @ translation_matrix(-pivot)
                )
                start = (maps.verify(turn @ best), turn @ best)
                for stage in params.stages[1:]:
                    start = maps.refine(start, stage, keep=False)
                found.append(start)
        return found


def slide_return(maps: SearchMaps, best: NDArray[np.float64], within: float) -> float:
    """How far (cells RMS over map 2's walls) the narrow refinement ends from ``best`` when
    restarted from ``best`` slid by each small move :func:`merging.evidence.pinning.pinning`
    tries, the farthest moves first; stops at the first end farther than ``within``.

    A restart that ends farther, where the maps still explain more than
    they contradict but at least ``ConfidenceParams.slide_settled_share``
    less than at ``best`` (net wall cells), fell into a worse optimum: it is
    left out, as one that came back. One that ends in conflict (net at most
    zero) stayed out of the narrow field's reach and still counts.
    """
    points = maps.second.points
    held = maps.verify(best).net
    worse = held - maps.params.confidence.slide_settled_share * abs(held)
    farthest = 0.0
    for move in reversed(slides(maps.params.confidence)):
        start = (maps.verify(move @ best), move @ best)
        for stage in maps.params.stages[1:]:
            start = maps.refine(start, stage, keep=False)
        distance = rms_between(start[1], best, points)
        if distance > within and 0.0 < start[0].net <= worse:
            continue
        farthest = max(farthest, distance)
        if farthest > within:
            break
    return farthest


def turned_rival(
    maps: SearchMaps, best: NDArray[np.float64], restarts: TurnedRestarts | None = None
) -> Candidate | None:
    """The placement explaining the most that refining ``best`` turned about the overlap
    finds farther than ``TomographicParams.near_rival_cells`` from it; None if none.

    Two optima of the narrow fields, one of them the truth, may lie a couple
    of cells apart at map 2's far walls and explain about as much
    (:class:`TurnedRestarts`, whose runs ``restarts`` may already hold): an
    optimum a turned start leads to farther than ``near_rival_cells``, not
    the start kept, is a rival.
    """
    if restarts is None:
        restarts = TurnedRestarts(maps, best)
    points = maps.second.points
    rival: Candidate | None = None
    for found in restarts.found():
        if rms_between(found[1], best, points) <= maps.params.near_rival_cells:
            continue
        if rival is None or found[0].net > rival[0].net:
            rival = found
    return rival


def both_ways(
    maps: SearchMaps, best: NDArray[np.float64]
) -> tuple[NDArray[np.float64], float, float]:
    """``best`` checked by refining the other way round: the placement halfway between the
    two, the factor the confidence takes, and how far apart they were (cells RMS).

    The refinement carries one map's walls down the other's smoothed walls,
    so where the overlap is small a turned map's rasterised walls (a
    staircase along a slanted wall) can pull it a cell or two aside, the
    farther the longer map 2's lever. Refining map 1 onto map 2 from the
    inverse of ``best`` on the same narrow fields meets the other map's
    staircase instead: the two answers straddle the truth, and how far
    apart they land map 2's walls says how well the overlap holds the
    placement. The factor is the logistic of ``ConfidenceParams.reverse_gap_cells``
    (the accuracy a merge is asked for) minus that distance, ``reverse_gap_width``
    wide; the placement reported lays map 2's walls halfway between.
    """
    params = maps.params
    reverse = SearchMaps(maps.second, maps.first, params)
    start = np.asarray(np.linalg.inv(best), dtype=np.float64)
    found = (reverse.verify(start), start)
    for stage in params.stages[1:]:
        found = reverse.refine(found, stage, keep=False)
    other = np.asarray(np.linalg.inv(found[1]), dtype=np.float64)
    points = maps.second.points
    gap = rms_between(other, best, points)
    confidence = params.confidence
    factor = float(expit((confidence.reverse_gap_cells - gap) / confidence.reverse_gap_width))
    return halfway(best, other, points), factor, gap


def rival_factor(
    maps: SearchMaps, best: NDArray[np.float64], rival: Candidate
) -> tuple[float, dict[str, float]]:
    """The distinctiveness factor of ``best`` against a near ``rival`` (the close fit's,
    :func:`merging.evidence.verify.confidence_factors`) and the measures behind it."""
    confidence = maps.params.confidence
    check = maps.verify(best)
    share = max(rival[0].net, 0.0) / check.net if check.net > 0 else 1.0
    factor = float(expit(((1.0 - share) - confidence.distinct_margin) / confidence.distinct_width))
    turn = matrix_to_pose(best)[2] - matrix_to_pose(rival[1])[2]
    measures = {
        "near_rival_share": share,
        "near_rival_distance_cells": rms_between(rival[1], best, maps.second.points),
        "near_rival_turn_deg": float(np.degrees(abs(wrap_angle(turn)))),
        "close_near_distinct": factor,
    }
    return factor, measures


def rigid_compromise(
    maps: SearchMaps, best: NDArray[np.float64]
) -> tuple[NDArray[np.float64], float]:
    """The best rigid compromise over the whole overlap of maps that bend, and how far it
    moved map 2's walls (cells RMS).

    The refinement's last fields, a cell wide or less, hold map 2 where one
    part of the overlap fits exactly, and the parts that bend away pull on
    nothing. Fields as wide as the bending (``TomographicParams.compromise``)
    let every part of the overlap pull, and the placement settles where the
    whole overlap fits best: the rigid transform a least-squares fit of
    corresponding points over the whole floor would give. A compromise
    farther than the bending (``RobustParams.distinct_cells``) is another
    answer, not the same one bent; then ``best`` is kept.
    """
    moved = refined_on(compromise_field(maps), maps.second, best, maps.params.compromise,
                        maps.params)  # fmt: skip
    distance = rms_between(moved, best, maps.second.points)
    if distance > maps.params.robust.distinct_cells:
        return best, 0.0
    return moved, distance


def compromise_field(maps: SearchMaps) -> SmoothedMap:
    """Map 1's fields for the compromise's widths (``TomographicParams.compromise``).

    At full resolution: a field computed on the half-resolution grid is off
    by up to a few cells at these widths, which the search's finer fields
    correct afterwards and the compromise, the last refinement, would not.
    """
    return SmoothedMap(
        maps.first.walls,
        maps.first.shape,
        downsample_from_sigma=2.0 * max(maps.params.compromise.sigmas),
        whole_field_share=maps.params.gauss_newton.whole_field_share,
    )
