"""Track each linked pair's transform between merge rounds; search globally only when needed.

:class:`TrackingEstimator` is a :data:`~tomosim.team.merger.PairEstimator`
for :class:`~tomosim.team.merger.TeamMerger`. Per pair and round it

1. collects the global search submitted at the pair's previous round, if any
   (:mod:`tomosim.team.worker`: it ran meanwhile in a worker process);
2. refines and verifies, on the current maps, the pair's tracked transform
   (the last one accepted) and the collected search's, if accepted
   (:func:`merging.tomographic.tracking.track_transform`), and returns the better of those
   accepted: a linked pair costs a refinement, not a search, and its
   transform does not jump between rounds. A search run on this round's
   maps themselves (a pair searched at the round's start) is taken as it
   judged them: refining its placement again on the same maps, without the
   rivals and restarts the search held it against, may settle on a nearby
   optimum that fits less well and be refused. A search's placement starts a
   track only when it also fits closely (``new_track_quality``); a track
   is kept at a lower confidence than a new placement needs
   (``keep_confidence``), and a track kept below that is marked
   :data:`~tomosim.team.merger.HELD_ONLY`: it keeps a link, but the merger
   does not count it as a round confirming one (the track refined its own
   placement; a wrong one, on maps that barely grew, holds as well as it
   did the round before);
3. submits a new global search, for the next round, when nothing could be
   tracked and either map gained walls since the pair's last search
   (``search_growth``, ``search_min_new_walls``: a pair refused on the same
   walls would be refused again) or the track was lost, or every
   ``search_every_rounds`` rounds of tracking (a second opinion, should the
   track have locked onto a wrong fit);
4. otherwise returns the last search's result, not accepted, with the reason.

A pair whose maps no track links yet, directly or through teammates,
cannot wait a round: the robots explore without each other's maps, and
re-explore what the other has seen. With ``search_unlinked_at_once``, such
pairs are searched in the round itself, before any pair is estimated
(:meth:`TrackingEstimator.prepare`, called by the merger at the start of a
round): the worker process and this one share the searches, and each pair
collects its own at step 1 of the same round. The maps are small then, and
the searches cheap.

The settings named are those of :class:`~tomosim.team.config.TrackingParams`,
the team's ``tracker``.

Searches are collected at a fixed step (the next round, or the same round
for maps not linked yet), so a run is the same whether they ran in the
worker process or inline. Compared with searching every pair every round,
an accepted search of two maps linked already through teammates takes
effect one round later.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from concurrent.futures import Future
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from merging.grid import OccupancyGrid, occupied_mask
from merging.result import MergeResult
from merging.tomographic.tracking import frame_matrix, frame_to_cells, track_transform
from merging.validators import RngLike, as_generator
from tomosim.team.config import TeamConfig
from tomosim.team.merger import HELD_ONLY
from tomosim.team.worker import Searches, searches

SEED_BOUND = 2**31
"""Seeds given to searches are drawn below this."""

Talks = Callable[[int, int], bool]
"""``talks(i, j)``: whether robots ``i`` and ``j`` can exchange maps this round."""


@dataclass(slots=True)
class _PairState:
    """What the tracker knows of one pair."""

    tracked: NDArray[np.float64] | None = None
    rounds_tracked: int = 0
    walls_at_search: tuple[int, int] | None = None
    last: MergeResult | None = None
    pending: Future[MergeResult] | None = None
    search_due: bool = False
    """A search is wanted and left to the start of the next round (:meth:`prepare`)."""
    search_on_round_maps: bool = False
    """The pending search runs on the maps of the round that collects it (:meth:`prepare`)."""


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

    __slots__ = ("_keep_params", "_pairs", "_rng", "_searches", "_urgent", "_walls", "config")

    def __init__(self, config: TeamConfig, *, rng: RngLike = None) -> None:
        self.config = config
        self._keep_params = config.tracker.keep_params(config.merger)
        self._searches: Searches = searches(worker=config.merge_worker)
        self._rng = as_generator(rng)
        self._pairs: dict[tuple[int, int], _PairState] = {}
        # Per robot, the grid its walls were last counted on and the count: a round asks
        # for each robot's grid once per pair it is in.
        self._walls: dict[int, tuple[OccupancyGrid, int]] = {}
        self._urgent: frozenset[tuple[int, int]] = frozenset()

    def tracked_groups(self, count: int) -> tuple[int, ...]:
        """Per robot of ``count``, the lowest robot its map is linked to by tracked pairs,
        directly or through teammates (its own number when no track links it)."""
        group = list(range(count))

        def root(k: int) -> int:
            while group[k] != k:
                k = group[k]
            return k

        for (i, j), state in sorted(self._pairs.items()):
            if state.tracked is not None and max(i, j) < count:
                low, high = sorted((root(i), root(j)))
                group[high] = low
        return tuple(root(k) for k in range(count))

    def _unlinked(self, count: int, talks: Talks | None) -> list[tuple[int, int]]:
        """The pairs, among those that can talk, whose maps no chain of tracks links."""
        groups = self.tracked_groups(count)
        return [
            (i, j)
            for i in range(count)
            for j in range(i + 1, count)
            if groups[i] != groups[j] and (talks is None or talks(i, j))
        ]

    def _due_now(
        self, grids: Sequence[OccupancyGrid], pairs: list[tuple[int, int]]
    ) -> list[tuple[tuple[int, int], tuple[int, int]]]:
        """Of ``pairs``, those a search is due for now (not tracked, none pending, and new
        walls since the last search or a track lost), each with its maps' wall counts."""
        walls = [self._wall_count(k, grid) for k, grid in enumerate(grids)]
        due = []
        for i, j in pairs:
            state = self._pairs.setdefault((i, j), _PairState())
            if state.tracked is not None or state.pending is not None:
                continue
            counts = (walls[i], walls[j])
            if state.search_due or self._grown(state, counts):
                due.append(((i, j), counts))
        return due

    def prepare(self, grids: Sequence[OccupancyGrid], talks: Talks | None = None) -> None:
        """Start of a round: search at once the pairs whose maps no track links yet (module
        docstring), when ``search_unlinked_at_once`` is set.

        A pair is searched now when no chain of tracked pairs links its two
        robots' maps, no search of it is pending, and it is due a search (its
        maps gained walls since its last one, or its track was lost). Each
        pair collects its search when the round estimates it (step 1).

        Parameters
        ----------
        grids : sequence of OccupancyGrid
            Every robot's grid of this round, in robot order.
        talks : callable, optional
            ``talks(i, j)``: whether the pair can exchange maps now (default:
            every pair can); pairs that cannot are not searched.
        """
        if not self.config.tracker.search_unlinked_at_once:
            self._urgent = frozenset()
            return
        unlinked = self._unlinked(len(grids), talks)
        self._urgent = frozenset(unlinked)
        for (i, j), walls in self._due_now(grids, unlinked):
            self._submit(self._pairs[(i, j)], grids[i], grids[j], walls)
            self._pairs[(i, j)].search_on_round_maps = True

    def round_wanted(self, grids: Sequence[OccupancyGrid], talks: Talks | None = None) -> bool:
        """Whether a round now could link maps not linked yet: a pair whose maps no track
        links has a search pending to collect, or is due one (:meth:`prepare`).

        The merger asks before a round between its regular ones
        (``unlinked_merge_interval``): a round that could only refuse again is
        left out. Same parameters as :meth:`prepare`.
        """
        unlinked = self._unlinked(len(grids), talks)
        if any(p in self._pairs and self._pairs[p].pending is not None for p in unlinked):
            return True
        return bool(self._due_now(grids, unlinked))

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
        if state.pending is not None:  # 1. the search of the last round or of this one's start
            # The pairs after this one collect theirs at this round too: while the
            # worker finishes one, this process may run the others it has not started.
            later = [s.pending for k, s in sorted(self._pairs.items()) if k > (first, second)]
            found = self._searches.wait(state.pending, [f for f in later if f is not None])
            state.pending = None
            state.last = found
        on_these_maps = found is not None and state.search_on_round_maps
        state.search_on_round_maps = False
        starts = [] if state.tracked is None else [(state.tracked, self._keep_params)]
        searched = None if found is None or not found.accepted else frame_matrix(found)
        best = None
        loose = None
        if searched is not None and on_these_maps:  # the search's own verdict on these maps
            assert found is not None
            if self._fits_closely(found):
                best = found
            else:
                loose = found
        elif searched is not None:
            starts.append((searched, self.config.merger))
        for start, params in starts:  # 2. refine and verify on today's maps
            tracked = track_transform(grid_1, grid_2, start, params=params)
            if start is searched and tracked.accepted and not self._fits_closely(tracked):
                loose = tracked
                continue
            if tracked.accepted and (best is None or tracked.confidence > best.confidence):
                best = tracked
        walls = (self._wall_count(first, grid_1), self._wall_count(second, grid_2))
        if best is not None:
            if best.confidence < self.config.merger.confidence.accept:  # kept, not found again
                best = replace(best, evidence={**best.evidence, HELD_ONLY: 1.0})
            state.tracked = frame_matrix(best)
            state.rounds_tracked = 0 if found is not None else state.rounds_tracked + 1
            if state.rounds_tracked >= self.config.tracker.search_every_rounds:  # 3. again
                self._submit(state, grid_1, grid_2, walls)
            return best
        lost = state.tracked is not None
        state.tracked = None
        state.rounds_tracked = 0
        due = lost or state.search_due or self._grown(state, walls)
        if due and (first, second) in self._urgent:
            # 3. no track links the pair's maps yet: search at the next round's start,
            # on that round's maps, and use the result at once
            state.search_due = True
            why = "searching globally at the start of the next round"
        elif due:  # 3. a lost track, or new walls: search again
            self._submit(state, grid_1, grid_2, walls)
            why = "searching globally; the result is used at the next round"
        elif found is not None and not found.accepted and (first, second) in self._urgent:
            why = "the global search of this round was not accepted"
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

    def _wall_count(self, robot: int, grid: OccupancyGrid) -> int:
        """The occupied cells of robot ``robot``'s ``grid``, counted once per grid."""
        known = self._walls.get(robot)
        if known is not None and known[0] is grid:
            return known[1]
        count = _walls(grid)
        self._walls[robot] = (grid, count)
        return count

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
        state.pending = self._searches.submit(
            grid_1, grid_2, method=self.method, seed=seed, options=self.config.search_options()
        )
        state.search_on_round_maps = False
        state.walls_at_search = walls
        state.rounds_tracked = 0
        state.search_due = False
