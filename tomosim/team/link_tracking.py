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
   track only when it also fits closely (``new_track_quality``); a track
   is kept at a lower confidence than a new placement needs
   (``keep_confidence``);
3. submits a new global search, for the next round, when nothing could be
   tracked and either map gained walls since the pair's last search
   (``search_growth``, ``search_min_new_walls``: a pair refused on the same
   walls would be refused again) or the track was lost, or every
   ``search_every_rounds`` rounds of tracking (a second opinion, should the
   track have locked onto a wrong fit);
4. otherwise returns the last search's result, not accepted, with the reason.

The settings named are those of :class:`~tomosim.team.config.TrackingParams`,
the team's ``tracker``.

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

from merging.grid import OccupancyGrid, occupied_mask
from merging.params import DEFAULT_PARAMS
from merging.result import MergeResult
from merging.tomographic.tracking import frame_matrix, frame_to_cells, track_transform
from merging.validators import RngLike, as_generator
from tomosim.team.config import TeamConfig
from tomosim.team.worker import Searches, searches

SEED_BOUND = 2**31
"""Seeds given to searches are drawn below this."""


@dataclass(slots=True)
class _PairState:
    """What the tracker knows of one pair."""

    tracked: NDArray[np.float64] | None = None
    rounds_tracked: int = 0
    walls_at_search: tuple[int, int] | None = None
    last: MergeResult | None = None
    pending: Future[MergeResult] | None = None


def _walls(grid: OccupancyGrid) -> int:
    return int(np.count_nonzero(occupied_mask(grid.data)))


class TrackingEstimator:
    """Pair estimates by tracking, with global searches in a worker (module docstring).

    Parameters
    ----------
    config : TeamConfig
        The team's settings; the tracker reads ``method`` (the global search's,
        :func:`merging.estimate_transform`), ``merge_worker`` (run global
        searches in a worker process, else inline; same results) and
        ``tracker``.
    rng : numpy.random.Generator, int or None
        Source of the searches' seeds.
    """

    __slots__ = ("_keep_params", "_pairs", "_rng", "_searches", "config")

    def __init__(self, config: TeamConfig, *, rng: RngLike = None) -> None:
        self.config = config
        self._keep_params = config.tracker.keep_params()
        self._searches: Searches = searches(worker=config.merge_worker)
        self._rng = as_generator(rng)
        self._pairs: dict[tuple[int, int], _PairState] = {}

    @property
    def method(self) -> str:
        """The global search's method."""
        return self.config.method

    def _fits_closely(self, result: MergeResult) -> bool:
        """Whether an accepted placement fits closely enough to start a track: its plain
        fit reaches ``new_track_quality``."""
        return result.evidence.get("quality", 0.0) >= self.config.tracker.new_track_quality

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
        starts = [] if state.tracked is None else [(state.tracked, self._keep_params)]
        searched = None if found is None or not found.accepted else frame_matrix(found)
        if searched is not None:
            starts.append((searched, DEFAULT_PARAMS))
        best = None
        loose = None
        for start, params in starts:  # 2. refine and verify on today's maps
            tracked = track_transform(grid_1, grid_2, start, params=params)
            if start is searched and tracked.accepted and not self._fits_closely(tracked):
                loose = tracked
                continue
            if tracked.accepted and (best is None or tracked.confidence > best.confidence):
                best = tracked
        walls = (_walls(grid_1), _walls(grid_2))
        if best is not None:
            state.tracked = frame_matrix(best)
            state.rounds_tracked = 0 if found is not None else state.rounds_tracked + 1
            if state.rounds_tracked >= self.config.tracker.search_every_rounds:  # 3. again
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
                f"{quality:.2f}, below {self.config.tracker.new_track_quality:.2f}); {why}"
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
        tracker = self.config.tracker
        return any(
            now - then >= max(tracker.search_min_new_walls, tracker.search_growth * then)
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
