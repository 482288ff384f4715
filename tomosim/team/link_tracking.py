"""Track each linked pair's transform between merge rounds; search globally only when needed.

:class:`TrackingEstimator` is a :data:`~tomosim.team.merger.PairEstimator`
for :class:`~tomosim.team.merger.TeamMerger`. Per pair and round it

1. collects the global search submitted at the pair's previous round, if any
   (:mod:`tomosim.team.worker`: it ran meanwhile in a worker process);
2. refines and verifies, on the current maps, the pair's tracked transform
   (the last one accepted) and the collected search's, if accepted
   (:func:`merging.tomographic.tracking.track_transform`), and returns the better of those
   accepted: a linked pair costs a refinement, not a search, and its
   transform does not jump between rounds. A search's placement starts a
   track only when it also fits closely (:data:`NEW_TRACK_QUALITY`); a track
   is kept at a lower confidence than a new placement needs
   (:data:`KEEP_CONFIDENCE`);
3. submits a new global search, for the next round, when nothing could be
   tracked and either map gained walls since the pair's last search
   (:data:`SEARCH_GROWTH`: a pair refused on the same walls would be refused
   again) or the track was lost, or every :data:`SEARCH_EVERY_ROUNDS` rounds of tracking (a
   second opinion, should the track have locked onto a wrong fit);
4. otherwise returns the last search's result, not accepted, with the reason.

Searches are collected at a fixed later step (the next round), so a run is
the same whether they ran in the worker process or inline. Compared with
searching every pair every round, an accepted search takes effect one round
later.
"""

from __future__ import annotations

from concurrent.futures import Future
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from merging.api import DEFAULT_METHOD
from merging.grid import OccupancyGrid, occupied_mask
from merging.params import DEFAULT_PARAMS
from merging.result import MergeResult
from merging.tomographic.tracking import frame_matrix, frame_to_cells, track_transform
from tomosim.team.worker import Searches, searches
from tomosim.worlds.world import RngLike, as_generator

SEARCH_EVERY_ROUNDS = 4
"""Rounds of tracking after which a pair is searched globally again."""
SEARCH_GROWTH = 0.1
"""Fraction of new occupied cells (in either map, since the pair's last search) that
makes an untracked pair worth searching again."""
SEARCH_MIN_NEW_WALLS = 20
"""New occupied cells that make an untracked pair worth searching again whatever the
fraction (a small map's first walls)."""
NEW_TRACK_QUALITY = DEFAULT_PARAMS.confidence.fit_centre
"""Plain fit (``evidence["quality"]``: agreement minus the weighed conflict, with no
tolerance for bent maps) a search's placement must reach on the current maps to start
a track: the centre of the default method's fit factor. Every later round verifies a
track without the search's runner-up and mirror checks, so it must begin where both
maps' walls meet cell for cell, as a team's maps (one sensor model, slow drift) mostly
do where a placement is right. In 30 episodes of the exploration study, 129 of the 131
right placements that started tracks fitted at 0.87 or better and two, in the cluttered
``fr079``, at 0.72 and 0.76 (they now wait for a later search); the one that started a
wrong track (a half turn of ``aces3``'s round hall, accepted on the fit tolerant of bent
maps, 0.90) fitted at 0.78."""
KEEP_CONFIDENCE = 0.5
"""Confidence at which a track, once started, is kept (new placements need
``ConfidenceParams.accept``, 0.6): hysteresis, as trackers confirm and drop tracks at
two thresholds. A track began at a placement accepted and fitting closely, and every
round since has verified it where it was; as robots' maps grow they bend against each
other, and a right track's confidence sinks, in the cluttered ``fr079`` of the
exploration study to 0.51-0.65. Held to 0.6, one episode there kept dropping its
tracks, lost all its links and took twice as long (499 s against 254 s) with no
wrong merge avoided. 0.5 is what every track was held to before acceptance moved to
0.6, over 352 study episodes without a false match."""
SEED_BOUND = 2**31
"""Seeds given to searches are drawn below this."""
KEEP_PARAMS = replace(
    DEFAULT_PARAMS, confidence=replace(DEFAULT_PARAMS.confidence, accept=KEEP_CONFIDENCE)
)
"""The default method's settings with the threshold of a kept track."""


@dataclass(slots=True)
class _PairState:
    """What the tracker knows of one pair."""

    tracked: NDArray[np.float64] | None = None
    rounds_tracked: int = 0
    walls_at_search: tuple[int, int] | None = None
    last: MergeResult | None = None
    pending: Future[MergeResult] | None = None


def _fits_closely(result: MergeResult) -> bool:
    """Whether an accepted placement fits closely enough to start a track.

    Its plain fit must reach :data:`NEW_TRACK_QUALITY`.
    """
    return result.evidence.get("quality", 0.0) >= NEW_TRACK_QUALITY


def _walls(grid: OccupancyGrid) -> int:
    return int(np.count_nonzero(occupied_mask(grid.data)))


class TrackingEstimator:
    """Pair estimates by tracking, with global searches in a worker (module docstring).

    Parameters
    ----------
    method : str
        The global search's method (:func:`merging.estimate_transform`).
    worker : bool
        Run global searches in a worker process (else inline; same results).
    rng : numpy.random.Generator, int or None
        Source of the searches' seeds.
    """

    __slots__ = ("_pairs", "_rng", "_searches", "method")

    def __init__(
        self, *, method: str = DEFAULT_METHOD, worker: bool = True, rng: RngLike = None
    ) -> None:
        self.method = method
        self._searches: Searches = searches(worker=worker)
        self._rng = as_generator(rng)
        self._pairs: dict[tuple[int, int], _PairState] = {}

    def __call__(
        self, first: int, second: int, grid_1: OccupancyGrid, grid_2: OccupancyGrid
    ) -> MergeResult:
        """This round's estimate of the pair ``(first, second)`` (steps 1-4)."""
        state = self._pairs.setdefault((first, second), _PairState())
        found = None
        if state.pending is not None:  # 1. last round's search
            # The pairs after this one collect theirs at this round too: while the
            # worker finishes one, this process may run the others it has not started.
            later = [s.pending for k, s in sorted(self._pairs.items()) if k > (first, second)]
            found = self._searches.wait(state.pending, [f for f in later if f is not None])
            state.pending = None
            state.last = found
        starts = [] if state.tracked is None else [(state.tracked, KEEP_PARAMS)]
        searched = None if found is None or not found.accepted else frame_matrix(found)
        if searched is not None:
            starts.append((searched, DEFAULT_PARAMS))
        best = None
        loose = None
        for start, params in starts:  # 2. refine and verify on today's maps
            tracked = track_transform(grid_1, grid_2, start, params=params)
            if start is searched and tracked.accepted and not _fits_closely(tracked):
                loose = tracked
                continue
            if tracked.accepted and (best is None or tracked.confidence > best.confidence):
                best = tracked
        walls = (_walls(grid_1), _walls(grid_2))
        if best is not None:
            state.tracked = frame_matrix(best)
            state.rounds_tracked = 0 if found is not None else state.rounds_tracked + 1
            if state.rounds_tracked >= SEARCH_EVERY_ROUNDS:  # 3. a second opinion
                self._submit(state, grid_1, grid_2, walls)
            return best
        lost = state.tracked is not None
        state.tracked = None
        state.rounds_tracked = 0
        if lost or self._grown(state, walls):  # 3. a lost track, or new walls: search again
            self._submit(state, grid_1, grid_2, walls)
            why = "searching globally; the result is used at the next round"
        elif loose is None and not (state.last is not None and state.last.accepted):
            why = "no new walls since the last global search, which was not accepted"
        else:
            why = "no new walls since the last global search"
        last = state.last
        if last is None:
            return MergeResult(np.eye(3), 0.0, False, self.method, reason=why)
        metres = frame_matrix(last)
        matrix = last.matrix  # the search's cells; the maps have grown since: recompute
        if metres is not None:
            matrix = frame_to_cells(metres, grid_1, grid_2)
        if loose is not None:  # the search accepted it; the plain fit did not
            quality = loose.evidence.get("quality", float("nan"))
            reason = (
                f"the search's placement fits too loosely to start tracking (plain fit "
                f"{quality:.2f}, below {NEW_TRACK_QUALITY:.2f}); {why}"
            )
        elif last.accepted:  # its placement did not start a track, or the track was lost
            reason = f"{why} (its placement fitted too loosely to track, or the track was lost)"
        else:
            reason = f"{why} ({last.reason or 'lost track'})"
        return replace(last, matrix=matrix, accepted=False, reason=reason)

    def _grown(self, state: _PairState, walls: tuple[int, int]) -> bool:
        """Whether either map gained walls enough since the pair's last search."""
        before = state.walls_at_search
        if before is None:
            return True
        return any(
            now - then >= max(SEARCH_MIN_NEW_WALLS, SEARCH_GROWTH * then)
            for now, then in zip(walls, before, strict=True)
        )

    def _submit(
        self,
        state: _PairState,
        grid_1: OccupancyGrid,
        grid_2: OccupancyGrid,
        walls: tuple[int, int],
    ) -> None:
        """Start a global search whose result the pair's next round collects."""
        seed = int(self._rng.integers(SEED_BOUND))
        state.pending = self._searches.submit(grid_1, grid_2, method=self.method, seed=seed)
        state.walls_at_search = walls
        state.rounds_tracked = 0
