"""Periodic team merging: every robot's grid merged with :func:`merging.merge_all`.

A merge round

1. estimates the transform of every pair of the robots' current grids
   (:func:`merging.estimate_transform`);
2. counts an estimate as *confirmed* when the merger accepted it in
   ``confirmations`` consecutive rounds with consistent transforms (within
   :data:`CONFIRM_ROTATION_DEG` and :data:`CONFIRM_TRANSLATION_M`); an
   estimate that is not accepted is never used, and one accepted only once
   is not used yet: a single wrong match, which would make a robot plan
   through walls, rarely repeats itself in the next round, which sees more
   of both maps;
3. links the maps by the maximum spanning forest of confirmed pairs and fuses
   the reference's group (:func:`merging.merge_all`);
4. composes, along the forest, each robot's map frame into the frame of its
   linked group's lowest-index robot (metres), so that any robot can see its
   teammates' grids in its own frame (:mod:`tomosim.team.sharing`);
5. scores every pair against the truth (:mod:`tomosim.team.quality`) and the
   merged map against the ground truth (:func:`merged_agreement`).

Only step 5 uses the true start poses; steps 1-4 see the grids alone.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from merging import available_methods, estimate_transform, merge_all
from merging.api import DEFAULT_METHOD
from merging.grid import OccupancyGrid
from merging.linking import MergeAllResult
from merging.result import MergeResult
from tomosim.team.quality import PairQuality, frame_errors, merged_agreement, pair_quality
from tomosim.worlds.world import RngLike, as_generator

CONFIRM_ROTATION_DEG = 3.0
"""Degrees two rounds' estimates of one pair may differ by and still confirm each
other: odometry drift moves an estimate by well under a degree between rounds,
while a wrong match is off by tens of degrees or by whole rooms."""
CONFIRM_TRANSLATION_M = 0.5
"""Metres two rounds' estimates may differ by (where each puts the second
robot's start position) and still confirm each other; same reasoning."""


@dataclass(frozen=True, slots=True)
class TeamMerge:
    """The outcome of one merge round.

    Attributes
    ----------
    step : int
        Simulation step after which the round ran.
    method : str
        The merging method.
    pairs : tuple of PairQuality
        Every pair ``(i, j)``, ``i < j``, in lexicographic order.
    groups : tuple of int
        Per robot, the lowest index of the group of robots its map is linked
        to through confirmed estimates (its own index when it is alone).
    frames : tuple of (3, 3) float ndarray
        Per robot, the rigid matrix taking its map frame to the map frame of
        robot ``groups[k]`` (metres); the identity for a robot alone.
    reference : int
        The robot whose frame ``merged`` is in (:func:`merging.merge_all`'s
        reference: robot 0, or the largest linked group's lowest index).
    merged : OccupancyGrid
        The fused map of the reference's group, in the reference's map frame.
    agreement : float
        :func:`merged_agreement` of ``merged`` with the ground truth.
    seconds : float
        Wall-clock time of steps 1-4 of the round (not the scoring).
    """

    step: int
    method: str
    pairs: tuple[PairQuality, ...]
    groups: tuple[int, ...]
    frames: tuple[NDArray[np.float64], ...]
    reference: int
    merged: OccupancyGrid
    agreement: float
    seconds: float

    @property
    def accepted(self) -> tuple[PairQuality, ...]:
        """The pairs whose estimate the merger accepted this round."""
        return tuple(p for p in self.pairs if p.accepted)

    @property
    def merged_robots(self) -> tuple[int, ...]:
        """Robots whose maps are fused into :attr:`merged`."""
        home = self.groups[self.reference]
        return tuple(k for k, g in enumerate(self.groups) if g == home)

    def linked(self, robot: int) -> bool:
        """Whether ``robot``'s map is linked to at least one other robot's."""
        return sum(g == self.groups[robot] for g in self.groups) > 1

    def relative(self, robot: int, other: int) -> NDArray[np.float64] | None:
        """Matrix taking ``other``'s map frame to ``robot``'s (metres), None if not linked."""
        if self.groups[robot] != self.groups[other]:
            return None
        return np.asarray(np.linalg.inv(self.frames[robot]) @ self.frames[other], np.float64)

    def as_dict(self) -> dict[str, Any]:
        """Plain values (for infos and JSON)."""
        return {
            "step": self.step,
            "method": self.method,
            "agreement": self.agreement,
            "accepted": len(self.accepted),
            "merged_robots": list(self.merged_robots),
            "pairs": {p.name: p.as_dict() for p in self.pairs},
        }


def _groups_and_frames(
    count: int, result: MergeAllResult
) -> tuple[tuple[int, ...], tuple[NDArray[np.float64], ...]]:
    """Step 4: each robot's group (lowest index) and frame -> group frame, along the forest."""
    groups = list(range(count))
    frames: list[NDArray[np.float64] | None] = [None] * count
    for root in range(count):
        if frames[root] is not None:
            continue
        frames[root] = np.eye(3)
        frontier = [root]
        while frontier:
            here = frontier.pop()
            known = frames[here]
            assert known is not None  # only placed robots enter the frontier
            for i, j in result.tree:
                other = j if here == i else i if here == j else None
                if other is None or frames[other] is not None:
                    continue
                into_here = result.pair(here, other).matrix_metres  # other's frame -> here
                if into_here is None:
                    raise ValueError("merge results lack metre transforms; merge OccupancyGrids")
                frames[other] = known @ into_here
                groups[other] = root
                frontier.append(other)
    return tuple(groups), tuple(np.asarray(f, dtype=np.float64) for f in frames)


class TeamMerger:
    """Merges all robots' grids every ``interval`` steps (module docstring).

    Parameters
    ----------
    method : str
        A method of :func:`merging.available_methods` (default the tomographic one).
    interval : int
        Steps between merge rounds: rounds run after steps ``interval``,
        ``2 * interval``, ...
    confirmations : int
        Consecutive rounds that must accept consistent estimates of a pair
        before the pair links maps (1: use an estimate as soon as it is accepted).
    rng : numpy.random.Generator, int or None
        Source of the merging methods' randomness; one stream serves all rounds.
    """

    __slots__ = ("_rng", "_streaks", "confirmations", "interval", "method")

    def __init__(
        self,
        *,
        method: str = DEFAULT_METHOD,
        interval: int = 50,
        confirmations: int = 2,
        rng: RngLike = None,
    ) -> None:
        if method not in available_methods():
            choices = ", ".join(available_methods())
            raise ValueError(f"unknown merging method {method!r}; choose one of: {choices}")
        for name, value in (("interval", interval), ("confirmations", confirmations)):
            if not (isinstance(value, int | np.integer) and value >= 1):
                raise ValueError(f"{name} must be a whole number >= 1, got {value!r}")
        self.method = method
        self.interval = int(interval)
        self.confirmations = int(confirmations)
        self._rng = as_generator(rng)
        self._streaks: dict[tuple[int, int], tuple[int, NDArray[np.float64]]] = {}

    def due(self, step: int) -> bool:
        """Whether a round runs after step ``step``."""
        return step > 0 and step % self.interval == 0

    def confirm(self, pair: tuple[int, int], result: MergeResult) -> int:
        """Step 2: take in this round's estimate of ``pair``; returns its run of consistent
        accepted rounds (0 when not accepted). Call once per pair and round."""
        metres = result.matrix_metres
        if not result.accepted or metres is None or not np.all(np.isfinite(metres)):
            self._streaks.pop(pair, None)
            return 0
        count, previous = self._streaks.get(pair, (0, metres))
        rotation, translation = frame_errors(metres, previous)
        consistent = rotation <= CONFIRM_ROTATION_DEG and translation <= CONFIRM_TRANSLATION_M
        streak = count + 1 if count and consistent else 1
        self._streaks[pair] = (streak, np.asarray(metres, dtype=np.float64))
        return streak

    def merge(
        self,
        step: int,
        grids: Sequence[OccupancyGrid],
        *,
        starts: ArrayLike,
        truth: OccupancyGrid,
    ) -> TeamMerge:
        """Run one merge round (steps 1-5 of the module docstring).

        Parameters
        ----------
        step : int
            The current step, stored in the result.
        grids : sequence of OccupancyGrid
            Each robot's grid in its own map frame, robot order.
        starts : (N, 3) array_like
            True start poses (for scoring only).
        truth : OccupancyGrid
            The world's ground-truth grid (for scoring only).
        """
        poses = np.asarray(starts, dtype=float)
        if poses.shape != (len(grids), 3):
            raise ValueError(
                f"starts must have shape ({len(grids)}, 3) (one pose per grid), got {poses.shape}"
            )
        index = {id(grid): k for k, grid in enumerate(grids)}
        if len(index) != len(grids):
            raise ValueError("grids must be distinct objects, one per robot")
        raw: dict[tuple[int, int], MergeResult] = {}
        streaks: dict[tuple[int, int], int] = {}

        def estimator(first: OccupancyGrid, second: OccupancyGrid) -> MergeResult:
            pair = (index[id(first)], index[id(second)])
            result = estimate_transform(first, second, method=self.method, rng=self._rng)
            raw[pair] = result
            streaks[pair] = self.confirm(pair, result)
            if result.accepted and streaks[pair] < self.confirmations:
                why = f"awaiting confirmation ({streaks[pair]} of {self.confirmations} rounds)"
                return replace(result, accepted=False, reason=why)
            return result

        clock = time.perf_counter()
        result = merge_all(list(grids), estimator=estimator)
        groups, frames = _groups_and_frames(len(grids), result)
        seconds = time.perf_counter() - clock
        pairs = tuple(
            pair_quality(
                raw[(i, j)],
                (grids[i], grids[j]),
                (poses[i], poses[j]),
                pair=(i, j),
                confirmed=streaks[(i, j)] >= self.confirmations,
                used=(i, j) in result.tree,
            )
            for i, j in sorted(raw)
        )
        merged = result.fused.grid
        if merged is None:  # OccupancyGrid inputs always give a georeferenced fused map
            raise ValueError("the fused map has no frame; merge OccupancyGrids")
        return TeamMerge(
            step=int(step),
            method=self.method,
            pairs=pairs,
            groups=groups,
            frames=frames,
            reference=int(result.reference),
            merged=merged,
            agreement=float(merged_agreement(merged, truth, poses[result.reference])),
            seconds=seconds,
        )
