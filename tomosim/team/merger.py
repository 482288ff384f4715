"""Periodic team merging: every robot's grid linked to its teammates' from the grids alone.

A merge round

0. lets the pair estimator prepare the round (``before_round``: the tracker
   starts the searches the round itself needs,
   :meth:`~tomosim.team.link_tracking.TrackingEstimator.prepare`);
1. estimates the transform of every pair of the robots' current grids, with
   :func:`merging.estimate_transform` or with the :data:`PairEstimator` given;
2. counts an estimate as *confirmed* when the merger accepted it in
   ``confirmations`` consecutive rounds with consistent transforms (within
   ``confirm_rotation_deg`` and ``confirm_translation_m``), or at once when
   it is at least ``confirm_at_once_confidence`` confident (all four settings
   of :class:`~tomosim.team.config.TeamConfig`), which counts as the whole run; an
   estimate that is not accepted is never used, and one accepted only once
   below that confidence is not used yet: a single wrong match, which would
   make a robot plan through walls, rarely repeats itself in the next round,
   which sees more of both maps, and the merger accepts its false matches
   at lower confidences. An estimate whose evidence says it was held only at
   a kept link's lower threshold (:data:`HELD_ONLY`) keeps a pair's run of
   rounds but does not lengthen it: a placement refined from itself on maps
   that barely grew repeats its own evidence, and confirms nothing (with no
   run to keep, it starts one, as any accepted estimate does);
3. links the maps through the confirmed pairs (:func:`merging.link_maps`, with
   the team's ``linking`` settings): a consistent spanning forest, each
   robot's frame placed in its group's root robot's frame;
4. fuses the main group (:func:`merging.linking.forest.fuse_group`).

Rounds run every ``merge_interval`` steps, and every
``unlinked_merge_interval`` steps while the robots' maps are not all linked
into one (:meth:`TeamMerger.due`): robots whose maps are not linked explore
without each other's maps and re-explore what the others have seen, so
each link is worth the extra rounds, which cost computing time, not
simulated time.

A round sees the grids alone, never the truth: scoring it against the true
start poses is :func:`tomosim.team.quality.score_round`'s job.
"""

from __future__ import annotations

import math
import re
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from merging import check_method, estimate_transform, link_maps
from merging.grid import OccupancyGrid
from merging.linking.forest import Linking, fuse_group
from merging.result import MergeResult
from merging.validators import RngLike, as_generator
from tomosim.frames import frame_errors

if TYPE_CHECKING:  # the configuration's module imports this one's estimator type
    from tomosim.team.config import TeamConfig

PairEstimator = Callable[[int, int, OccupancyGrid, OccupancyGrid], MergeResult]
"""``estimator(i, j, grid_i, grid_j) -> MergeResult`` for robots ``i < j``: its matrix
takes grid ``j``'s cells to grid ``i``'s and its ``matrix_metres`` frame ``j`` to
frame ``i``."""
RoundStart = Callable[[Sequence[OccupancyGrid]], None]
"""``before_round(grids)``: called with every robot's grid at the start of a round, before
any pair is estimated."""
RoundWanted = Callable[[Sequence[OccupancyGrid]], bool]
"""``round_wanted(grids)``: whether the pair estimator could link maps in a round now."""
HELD_ONLY = "held_only"
"""Key of ``MergeResult.evidence`` set (to 1.0) by a pair estimator whose estimate is
accepted only at the lower threshold at which a link, once made, is kept (the tracker's
``keep_confidence``): it holds the pair's run of consistent rounds but does not count as
a round of it (module docstring, step 2)."""


def robot_name(index: int) -> str:
    """Short name of robot ``index`` in reports, infos and recordings: ``"r0"``, ``"r1"``, ...

    The PettingZoo environment calls the same robot's agent ``robot_0``
    (``envs.multi_robot_exploration_v0.agent_name``); infos key pairs by these
    short names (``"r0-r1"``).
    """
    return f"r{index}"


def pair_name(first: int, second: int) -> str:
    """``"r0-r1"``: a pair's name in reports, infos and recordings."""
    return f"{robot_name(first)}-{robot_name(second)}"


def pair_order(name: str) -> tuple[float, float, str]:
    """Sort key of a pair's name by its robots' numbers: ``r0-r2`` before ``r0-r10``
    (names of another form after them, as text)."""
    numbers = re.fullmatch(r"r(\d+)-r(\d+)", name)
    if numbers is None:
        return (math.inf, math.inf, name)
    return (float(numbers[1]), float(numbers[2]), "")


@dataclass(frozen=True, slots=True)
class PairOutcome:
    """One pair's estimate in a merge round, as the merger saw it.

    Attributes
    ----------
    first, second : int
        Robots ``i < j``; the estimate takes ``second``'s map to ``first``'s.
    result : MergeResult
        The estimate as the merging method returned it.
    confirmed : bool
        Accepted in enough consecutive rounds with consistent estimates
        (module docstring, step 2); only confirmed estimates link maps.
    used : bool
        The estimate is an edge of the spanning forest that links the maps.
    dropped : bool
        Confirmed, but left out because it contradicts the other links.
    """

    first: int
    second: int
    result: MergeResult
    confirmed: bool
    used: bool
    dropped: bool = False

    @property
    def name(self) -> str:
        """``"r0-r1"``."""
        return pair_name(self.first, self.second)

    @property
    def accepted(self) -> bool:
        """The merging method vouched for the estimate."""
        return self.result.accepted


@dataclass(frozen=True, slots=True)
class TeamMerge:
    """The outcome of one merge round (it knows nothing of the truth).

    Attributes
    ----------
    step : int
        Simulation step after which the round ran.
    method : str
        The merging method.
    pairs : tuple of PairOutcome
        Every pair ``(i, j)``, ``i < j``, in lexicographic order.
    linking : Linking
        How the confirmed pairs link the maps (:func:`merging.link_maps`).
    merged : OccupancyGrid
        The fused map of the main group, in the map frame of its root robot
        (:attr:`reference`).
    seconds : float
        Wall-clock time of the round.
    """

    step: int
    method: str
    pairs: tuple[PairOutcome, ...]
    linking: Linking
    merged: OccupancyGrid
    seconds: float

    @property
    def reference(self) -> int:
        """The robot whose map frame :attr:`merged` is in."""
        return self.linking.main

    @property
    def groups(self) -> tuple[int, ...]:
        """Per robot, the lowest index of the group its map is linked to (its own when alone)."""
        return self.linking.roots

    @property
    def frames(self) -> tuple[NDArray[np.float64], ...]:
        """Per robot, the matrix taking its map frame to its group root's map frame (metres)."""
        metres = self.linking.transforms_metres
        assert metres is not None  # robots' grids are OccupancyGrids
        return metres

    @property
    def accepted(self) -> tuple[PairOutcome, ...]:
        """The pairs whose estimate the merging method accepted this round."""
        return tuple(p for p in self.pairs if p.accepted)

    @property
    def merged_robots(self) -> tuple[int, ...]:
        """Robots whose maps are fused into :attr:`merged`."""
        return self.linking.group(self.reference)

    def linked(self, robot: int) -> bool:
        """Whether ``robot``'s map is linked to at least one other robot's."""
        return self.linking.linked(robot)

    def relative(self, robot: int, other: int) -> NDArray[np.float64] | None:
        """Matrix taking ``other``'s map frame to ``robot``'s (metres), None if not linked."""
        if self.groups[robot] != self.groups[other]:
            return None
        return np.asarray(np.linalg.inv(self.frames[robot]) @ self.frames[other], np.float64)


class TeamMerger:
    """Merges all robots' grids every ``config.merge_interval`` steps (module docstring).

    Parameters
    ----------
    config : TeamConfig
        The team's settings; the merger reads ``method`` (a method of
        :func:`merging.available_methods`, or, with ``estimator``, the name it
        is reported under), ``merge_interval`` and ``unlinked_merge_interval``
        (:meth:`due`), ``confirmations``, ``confirm_at_once_confidence``,
        ``confirm_rotation_deg``, ``confirm_translation_m`` and ``linking``.
    rng : numpy.random.Generator, int or None
        Source of the merging methods' randomness; one stream serves all rounds.
    estimator : PairEstimator, optional
        Estimates a pair instead of ``merging.estimate_transform(grid_i, grid_j,
        method=config.method)``.
    before_round : RoundStart, optional
        Called with the grids at the start of every round (step 0).
    round_wanted : RoundWanted, optional
        Asked before a round between the regular ones (:meth:`due`); without
        it, every such round runs.
    """

    __slots__ = (
        "_all_linked",
        "_before_round",
        "_estimator",
        "_rng",
        "_round_wanted",
        "_streaks",
        "config",
    )

    def __init__(
        self,
        config: TeamConfig,
        *,
        rng: RngLike = None,
        estimator: PairEstimator | None = None,
        before_round: RoundStart | None = None,
        round_wanted: RoundWanted | None = None,
    ) -> None:
        if estimator is None:
            check_method(config.method)
        self.config = config
        self._rng = as_generator(rng)
        self._estimator = estimator
        self._before_round = before_round
        self._round_wanted = round_wanted
        self._streaks: dict[tuple[int, int], tuple[int, NDArray[np.float64]]] = {}
        self._all_linked = False

    @property
    def method(self) -> str:
        """The merging method, as rounds report it."""
        return self.config.method

    @property
    def interval(self) -> int:
        """Steps between merge rounds now: ``merge_interval`` once the last round linked all
        robots' maps into one, else the shorter of it and ``unlinked_merge_interval``
        (from the start, before any round)."""
        if self._all_linked:
            return self.config.merge_interval
        return min(self.config.merge_interval, self.config.unlinked_merge_interval)

    def due(self, step: int, grids: Callable[[], Sequence[OccupancyGrid]] | None = None) -> bool:
        """Whether a round runs after step ``step``.

        Every multiple of ``merge_interval`` is a regular round. While the maps
        are not all linked into one, every multiple of :attr:`interval` is a
        round too, when it can change something: a pair awaits its
        confirmation, or the pair estimator could link maps (``round_wanted``,
        asked with ``grids()``, the robots' grids now; a round that could only
        refuse the same pairs on the same maps again costs time for nothing).
        Without ``grids`` or ``round_wanted`` every such round runs.
        """
        if step <= 0 or step % self.interval != 0:
            return False
        if step % self.config.merge_interval == 0:
            return True
        if grids is None or self._round_wanted is None:
            return True
        needed = self.config.confirmations
        if any(count < needed for count, _ in self._streaks.values()):
            return True
        return self._round_wanted(grids())

    def estimate(self, i: int, j: int, grids: Sequence[OccupancyGrid]) -> MergeResult:
        """Step 1 for the pair ``(i, j)``."""
        if self._estimator is not None:
            result = self._estimator(i, j, grids[i], grids[j])
            if not isinstance(result, MergeResult):
                raise TypeError(f"the estimator returned {type(result).__name__}, not MergeResult")
            return result
        return estimate_transform(
            grids[i], grids[j], method=self.method, rng=self._rng, **self.config.search_options()
        )

    def confirm(self, pair: tuple[int, int], result: MergeResult) -> int:
        """Step 2: take in this round's estimate of ``pair``; returns its run of consistent
        accepted rounds (0 when not accepted). Call once per pair and round.

        An estimate held only at a kept link's threshold (:data:`HELD_ONLY`),
        consistent with the run, leaves the run as it was; with no run (after a
        round that refused the pair or could not reach it) or not consistent
        with it, it starts a new run of one, as any accepted estimate does: it
        never lengthens a run, but counts as the first round of one. A confident
        estimate (:meth:`confident`) counts as a whole run of ``confirmations``
        rounds, so a link it makes is kept by the rounds that follow as a link
        confirmed round by round is.
        """
        metres = result.matrix_metres
        if not result.accepted or metres is None or not np.all(np.isfinite(metres)):
            self._streaks.pop(pair, None)
            return 0
        count, previous = self._streaks.get(pair, (0, metres))
        rotation, translation = frame_errors(metres, previous)
        consistent = (
            rotation <= self.config.confirm_rotation_deg
            and translation <= self.config.confirm_translation_m
        )
        held_only = bool(result.evidence.get(HELD_ONLY))
        streak = (count if held_only else count + 1) if count and consistent else 1
        if self.confident(result):
            # A whole run at once: the link then stays while later rounds hold it, as a
            # run confirmed round by round does.
            streak = max(streak, self.config.confirmations)
        self._streaks[pair] = (streak, np.asarray(metres, dtype=np.float64))
        return streak

    def confident(self, result: MergeResult) -> bool:
        """Whether an accepted ``result`` links maps without waiting for its run of rounds:
        at least ``confirm_at_once_confidence`` confident (never when that is None), and
        not held only at a kept link's lower threshold (:data:`HELD_ONLY`)."""
        threshold = self.config.confirm_at_once_confidence
        return (
            threshold is not None
            and result.accepted
            and result.confidence >= threshold
            and not result.evidence.get(HELD_ONLY)
        )

    def merge(self, step: int, grids: Sequence[OccupancyGrid]) -> TeamMerge:
        """Run one merge round (steps 1-4 of the module docstring).

        Parameters
        ----------
        step : int
            The current step, stored in the result.
        grids : sequence of OccupancyGrid
            Each robot's grid in its own map frame, robot order.
        """
        if not all(isinstance(g, OccupancyGrid) for g in grids):
            raise TypeError("grids must be OccupancyGrids, one per robot in robot order")
        clock = time.perf_counter()
        count = len(grids)
        if self._before_round is not None:
            self._before_round(grids)
        raw: dict[tuple[int, int], MergeResult] = {}
        confirmed: dict[tuple[int, int], MergeResult] = {}
        for i in range(count):
            for j in range(i + 1, count):
                result = self.estimate(i, j, grids)
                raw[(i, j)] = result
                streak = self.confirm((i, j), result)
                needed = self.config.confirmations
                if result.accepted and streak < needed:
                    why = f"awaiting confirmation ({streak} of {needed} rounds)"
                    result = replace(result, accepted=False, reason=why)
                confirmed[(i, j)] = result
        linking = link_maps(grids, confirmed, params=self.config.linking)
        self._all_linked = len(set(linking.roots)) == 1
        merged = fuse_group(grids, linking, linking.main).grid
        assert merged is not None  # OccupancyGrid inputs give a georeferenced fused map
        pairs = tuple(
            PairOutcome(
                i,
                j,
                raw[(i, j)],
                confirmed=confirmed[(i, j)].accepted,
                used=(i, j) in linking.used,
                dropped=(i, j) in linking.dropped,
            )
            for i, j in sorted(raw)
        )
        seconds = time.perf_counter() - clock
        return TeamMerge(int(step), self.method, pairs, linking, merged, seconds)
