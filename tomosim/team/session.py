"""A team exploring together: the simulation, periodic merging, shared maps and coverage.

:class:`TeamSession` is what both the PettingZoo environment and the episode
runner drive. One :meth:`TeamSession.step`

1. advances the simulation under the robots' commands;
2. updates the team coverage and credits each robot with the free space the
   team knows for the first time (:mod:`tomosim.team.coverage`);
3. finds who can talk to whom (:mod:`tomosim.team.comms`; everyone, without
   a communication range);
4. every ``merge_interval`` steps (``unlinked_merge_interval`` while the
   robots' maps are not all linked into one), when merging is on, runs a merge
   round (:class:`~tomosim.team.merger.TeamMerger`, from the grids alone, over the
   pairs that can talk), adopts its links, and scores it against the truth
   (:func:`~tomosim.team.quality.score_round`);
5. rebuilds the teammate layers that are due, each robot taking in the grids
   of the linked teammates it reaches (:mod:`tomosim.team.sharing`).

The merging method ``"oracle"`` merges with the true start poses
(:mod:`tomosim.team.oracle`): the session, which holds them, hands the
merger an estimator that knows them, and merging itself never sees them.

All randomness comes from the generator given at construction: one stream
for the simulation (start poses, odometry, lidar) and one for the merger.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from merging import estimate_transform
from merging.api import DEFAULT_METHOD
from merging.grid import OccupancyGrid
from merging.result import MergeResult
from merging.validators import RngLike, as_generator
from tomosim.simulation import Simulation
from tomosim.team.comms import in_range, out_of_reach, reach_groups
from tomosim.team.config import TeamConfig
from tomosim.team.coverage import TeamCoverage
from tomosim.team.link_tracking import TrackingEstimator
from tomosim.team.merger import PairEstimator, TeamMerge, TeamMerger
from tomosim.team.oracle import ORACLE, oracle_estimator
from tomosim.team.quality import RoundQuality, score_round
from tomosim.team.sharing import SharedMaps
from tomosim.worlds.world import World


class TeamSession:
    """Robots exploring one world as a team (steps 1-5 of the module docstring).

    Parameters
    ----------
    world : World
        The world.
    robots : int
        Number of robots, placed at random free poses with random headings.
    config : TeamConfig, optional
        Every setting of the team (defaults as documented there).
    rng : numpy.random.Generator, int or None
        The session's only source of randomness.

    Attributes
    ----------
    simulation : Simulation
    coverage : TeamCoverage
    shared : SharedMaps
    merger : TeamMerger or None
        None when merging is off.
    last_merge : TeamMerge or None
        The latest merge round.
    last_quality : RoundQuality or None
        The latest merge round scored against the truth.
    rewards : (N,) float ndarray
        Square metres of free space each robot discovered for the team at the
        last step.
    reach : (N,) int ndarray
        Per robot, the label of its communication group at the current step:
        robots reach each other when their labels are equal (all equal without
        a communication range).
    """

    __slots__ = (
        "_grids",
        "config",
        "coverage",
        "last_merge",
        "last_quality",
        "merger",
        "reach",
        "rewards",
        "shared",
        "simulation",
    )

    def __init__(
        self,
        world: World,
        *,
        robots: int,
        config: TeamConfig | None = None,
        rng: RngLike = None,
    ) -> None:
        self.config = config if config is not None else TeamConfig()
        if not isinstance(self.config, TeamConfig):
            raise TypeError(f"config must be a TeamConfig, got {type(self.config).__name__}")
        sim_rng, merge_rng = as_generator(rng).spawn(2)
        self.simulation = Simulation(
            world, robots=robots, config=self.config.simulation, rng=sim_rng
        )
        count = self.simulation.count
        self.reach = self._reach_groups()
        self.merger = self._merger(merge_rng) if self.config.merge else None
        self.shared = SharedMaps(count, refresh_interval=self.config.share_interval)
        self.coverage = TeamCoverage(
            world,
            self.simulation.start_poses,
            resolution=self.config.simulation.mapping.resolution,
        )
        self.last_merge: TeamMerge | None = None
        self.last_quality: RoundQuality | None = None
        self._grids: list[OccupancyGrid] | None = None
        self.rewards = self.coverage.update(self.grids())
        for grid_map in self.simulation.maps:  # from now on, coverage follows what is new
            grid_map.start_journal()

    @property
    def count(self) -> int:
        """Number of robots."""
        return self.simulation.count

    @property
    def steps(self) -> int:
        """Steps taken."""
        return self.simulation.steps

    @property
    def world(self) -> World:
        """The world explored."""
        return self.simulation.world

    def grids(self) -> list[OccupancyGrid]:
        """Each robot's own grid in its map frame (read-only, cached for the current step)."""
        if self._grids is None:
            self._grids = [self.simulation.grid(k) for k in range(self.count)]
        return self._grids

    def _merger(self, rng: np.random.Generator) -> TeamMerger:
        """The team's merger with its pair estimator (:meth:`_estimator`) and, with the
        tracker, the tracker's start of a round (searches the round itself needs, among
        the pairs that can talk)."""
        tracker = None
        if self.config.tracking and self.config.method == DEFAULT_METHOD:
            tracker = TrackingEstimator(self.config, rng=rng)
        estimator = self._estimator(rng, tracker)
        if tracker is None:
            return TeamMerger(self.config, rng=rng, estimator=estimator)
        talks = None if self.config.comms.unlimited else self.reaches

        def before_round(grids: Sequence[OccupancyGrid]) -> None:
            tracker.prepare(grids, talks)

        def round_wanted(grids: Sequence[OccupancyGrid]) -> bool:
            return tracker.round_wanted(grids, talks)

        return TeamMerger(
            self.config,
            rng=rng,
            estimator=estimator,
            before_round=before_round,
            round_wanted=round_wanted,
        )

    def _estimator(
        self, rng: np.random.Generator, tracker: TrackingEstimator | None
    ) -> PairEstimator | None:
        """The merger's pair estimator: the oracle's, the tracker (the default method,
        with tracking) or None (the method's own search every round); without a
        communication range as it is, else asked only for the pairs that can talk."""
        method, options = self.config.method, self.config.search_options()
        base: PairEstimator | None = tracker
        if method == ORACLE:
            base = oracle_estimator(
                self.simulation.start_poses,
                error_deg=self.config.oracle_error_deg,
                error_m=self.config.oracle_error_m,
                min_shared_m2=self.config.oracle_min_shared_m2,
            )
        if self.config.comms.unlimited:
            return base

        def estimate(i: int, j: int, grid_i: OccupancyGrid, grid_j: OccupancyGrid) -> MergeResult:
            if self.reach[i] != self.reach[j]:
                return out_of_reach(i, j, method)
            if base is not None:
                return base(i, j, grid_i, grid_j)
            return estimate_transform(grid_i, grid_j, method=method, rng=rng, **options)

        return estimate

    def _reach_groups(self) -> NDArray[np.intp]:
        """Step 3: every robot's communication group now (:mod:`tomosim.team.comms`)."""
        comms = self.config.comms
        if comms.unlimited:
            return np.zeros(self.count, dtype=np.intp)
        positions = self.simulation.true_poses[:, :2]
        return reach_groups(in_range(positions, comms, self.world.walls))

    def step(self, commands: ArrayLike) -> RoundQuality | None:
        """Advance one step (module docstring); returns the merge round run, if any, scored."""
        self.simulation.step(commands)
        self._grids = None
        self.rewards = self.coverage.reveal([m.take_journal() for m in self.simulation.maps])
        if not self.config.comms.unlimited:  # without a range, everyone stays in reach
            self.reach = self._reach_groups()
        reach = None if self.config.comms.unlimited else self.reach
        scored = None
        if self.merger is not None and self.merger.due(self.steps, self.grids):
            grids = self.grids()
            merge = self.merger.merge(self.steps, grids)
            scored = score_round(merge, grids, self.simulation.start_poses, self.world.truth)
            self.last_merge, self.last_quality = merge, scored
            self.shared.link(merge, reach=reach)
        if self.shared.due(self.steps):
            self.shared.refresh(self.steps, self.grids(), reach=reach)
        return scored

    def reaches(self, robot: int, other: int) -> bool:
        """Whether ``robot`` can talk to ``other`` now, directly or through relays."""
        return bool(self.reach[robot] == self.reach[other])

    def contacts(self, robot: int) -> dict[int, NDArray[np.float64]]:
        """The teammates robot ``robot`` coordinates with now, each with the matrix taking
        its map frame to robot ``robot``'s (metres): those its map is linked to by merges
        and that it reaches at this step (it learns their poses and targets)."""
        return {k: m for k, m in self.shared.links(robot).items() if self.reaches(robot, k)}

    def linked(self, robot: int) -> bool:
        """Whether robot ``robot``'s best map includes teammates' maps."""
        return bool(self.shared.teammates(robot))

    def best_map(self, robot: int) -> OccupancyGrid:
        """Robot ``robot``'s best map, in its own map frame (:mod:`tomosim.team.sharing`)."""
        return self.shared.best_grid(robot, self.grids())

    def best_crop(self, robot: int, *, size: int, pool: int) -> NDArray[np.int8]:
        """A window of the best map around the robot's pose estimate (:meth:`SharedMaps.crop`)."""
        pose = self.simulation.odometry[robot].pose
        own = self.simulation.maps[robot]
        return self.shared.crop_cells(
            robot, own.cells, own.anchor, own.config.resolution, pose[:2], size=size, pool=pool
        )

    def best_crops(self, out: NDArray[np.int8], *, pool: int) -> None:
        """:meth:`best_crop` of every robot, robot ``k``'s into ``out[k]``: ``out`` is a
        C-contiguous ``(N, size, size)`` int8 array."""
        shared = self.shared
        simulation = self.simulation
        for robot, (own, odometry) in enumerate(
            zip(simulation.maps, simulation.odometry, strict=True)
        ):
            x, y, _ = odometry.pose.tolist()
            shared.crop_into(
                out[robot], robot, own.cells, own.anchor, own.config.resolution, x, y, pool=pool
            )
