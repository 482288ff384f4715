"""Frontier-based exploration: choose a reachable frontier, drive there, repeat.

Each call of :meth:`FrontierPolicy.act` returns one command. Every
``replan_interval`` steps, or when the current path is done, the policy

1. builds the inflated planning grid of the map it is given
   (:mod:`~tomosim.exploration.planning`);
2. runs a wavefront from the robot's cell;
3. finds the frontier clusters (:mod:`~tomosim.exploration.frontiers`) and
   the cost of reaching each of their cells (the candidates of
   :mod:`~tomosim.exploration.targets`);
4. lets its *target chooser* pick a cell, from the candidates and what it
   knows of its teammates (by default the nearest cluster, less a bonus for
   its size; :data:`~tomosim.exploration.choosers.CHOOSERS`), and follows the
   path there (:mod:`~tomosim.exploration.controller`).

The target is kept until it is reached or stops being a frontier, so that
the robot does not dither between two frontiers of nearly equal cost; a
coordinated chooser also gives it up to a teammate that has taken a target
within ``claim_radius`` of it and is nearer to it. A robot
that barely moves for ``stuck_steps`` steps backs off for ``recovery_steps``
steps; after :data:`MAX_FAILURES` such failures, or on reaching a target that
is still a frontier, it abandons the target (frontier cells near it are not
chosen again). Exploration is *finished* when no frontier can be
reached.

The map may be the robot's own or a merged one: either way it must be placed
in the frame the pose is given in (its origin, yaw included, says where; see
:func:`tomosim.frames.place_grid`). Call :meth:`FrontierPolicy.reset` when switching to a
map in another frame.
"""

from __future__ import annotations

import itertools
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from merging.grid import OccupancyGrid
from merging.validators import real_number, whole_number
from tomosim.exploration.choosers import make_chooser
from tomosim.exploration.controller import ControllerConfig, PathFollower
from tomosim.exploration.planning import PlannerConfig, PlanningGrid, Wavefront, planning_grid
from tomosim.exploration.targets import Candidate, TargetChooser, Teammate
from tomosim.kernels.planning import frontier_groups
from tomosim.lidar import Scan

RECOVERY_COMMAND = (-0.3, 0.6)
"""Normalised (linear, angular) command while backing off after getting stuck."""
MAX_FAILURES = 2
"""Times a robot may get stuck on the way to one target before abandoning it."""


@dataclass(frozen=True)
class ExplorationConfig:
    """Parameters of :class:`FrontierPolicy`.

    Attributes
    ----------
    planner : PlannerConfig
        Planning grid and inflation.
    controller : ControllerConfig
        Path following.
    min_frontier_size : int
        Planning cells below which a frontier cluster is ignored.
    size_bonus : float
        Metres of path a cluster's size is worth per metre of frontier.
    replan_interval : int
        Steps between replans while a path is being followed.
    stuck_steps : int
        Steps over which moving less than ``stuck_distance`` counts as stuck.
    stuck_distance : float
        Metres.
    recovery_steps : int
        Steps of backing off after getting stuck.
    blacklist_radius : float
        Metres around an abandoned target where no frontier is chosen again.
    start_search_radius : float
        How far (metres) to look for a passable cell when the robot's own cell
        is inside the inflated walls.
    claim_radius : float
        Metres: a coordinated robot gives up its target when a teammate
        nearer to it has taken a target this close (the same frontier seen
        on two maps lies a few cells apart).
    """

    planner: PlannerConfig = field(default_factory=PlannerConfig)
    controller: ControllerConfig = field(default_factory=ControllerConfig)
    min_frontier_size: int = 4
    size_bonus: float = 0.5
    replan_interval: int = 10
    stuck_steps: int = 30
    stuck_distance: float = 0.15
    recovery_steps: int = 8
    blacklist_radius: float = 0.6
    start_search_radius: float = 1.0
    claim_radius: float = 1.0

    def __post_init__(self) -> None:
        for name in ("min_frontier_size", "replan_interval", "stuck_steps"):
            whole_number(getattr(self, name), name, minimum=1)
        for name in (
            "size_bonus",
            "stuck_distance",
            "blacklist_radius",
            "start_search_radius",
            "claim_radius",
        ):
            real_number(getattr(self, name), name, low=0.0)
        whole_number(self.recovery_steps, "recovery_steps", minimum=0)


def _start_cell(
    planning: PlanningGrid, position: NDArray[np.float64], radius: float
) -> tuple[int, int] | None:
    """The robot's planning cell, or the nearest passable one within ``radius`` metres."""
    cell = planning.to_cells(position)
    if planning.inside(cell)[0] and np.isfinite(planning.costs[cell[0, 1], cell[0, 0]]):
        return (int(cell[0, 0]), int(cell[0, 1]))
    passable = np.argwhere(np.isfinite(planning.costs))[:, ::-1]  # (x, y), row by row
    if len(passable) == 0:
        return None
    distance = np.hypot(*(planning.to_frame(passable) - position).T)
    best = int(np.argmin(distance))
    if distance[best] > radius:
        return None
    return (int(passable[best, 0]), int(passable[best, 1]))


class FrontierPolicy:
    """Frontier exploration for one robot (steps 1-4 of the module docstring).

    Parameters
    ----------
    config : ExplorationConfig, optional
        Defaults as documented there.
    chooser : TargetChooser or str
        The target chooser, or its name in
        :data:`~tomosim.exploration.choosers.CHOOSERS` (default ``"nearest"``).
    """

    __slots__ = (
        "_failures",
        "_history",
        "_planning",
        "_recovery",
        "_since_plan",
        "_wave",
        "blacklist",
        "chooser",
        "config",
        "finished",
        "follower",
        "target",
    )

    def __init__(
        self, config: ExplorationConfig | None = None, *, chooser: TargetChooser | str = "nearest"
    ) -> None:
        self.config = config if config is not None else ExplorationConfig()
        self.chooser = make_chooser(chooser) if isinstance(chooser, str) else chooser
        self.follower = PathFollower(self.config.controller)
        self.reset()

    def reset(self) -> None:
        """Forget the path, the target, the abandoned targets and the last plan."""
        self.follower.set_path(np.zeros((0, 2)))
        self.target: NDArray[np.float64] | None = None
        self.blacklist: list[NDArray[np.float64]] = []
        self.finished = False
        self._history: deque[NDArray[np.float64]] = deque(maxlen=self.config.stuck_steps)
        self._recovery = 0
        self._since_plan = 0
        self._failures = 0
        self._planning: PlanningGrid | None = None
        self._wave: Wavefront | None = None

    def act(
        self,
        pose: ArrayLike,
        grid: OccupancyGrid,
        *,
        scan: Scan | None = None,
        teammates: Sequence[Teammate] = (),
    ) -> NDArray[np.float64]:
        """The normalised ``(linear, angular)`` command for this step.

        Parameters
        ----------
        pose : (3,) array_like
            The robot's pose ``(x, y, theta)`` in the frame ``grid`` is placed in.
        grid : OccupancyGrid
            The map to explore (the robot's own, or a merged one).
        scan : Scan, optional
            The latest scan, for the controller's guard against collisions.
        teammates : sequence of Teammate
            What the robot knows of its teammates, in the same frame (none:
            it explores alone). Only coordinated choosers use it.
        """
        position = np.asarray(pose, dtype=float)
        if position.shape != (3,) or not np.all(np.isfinite(position)):
            raise ValueError(f"pose must be a finite (x, y, theta), got {pose!r}")
        cfg = self.config
        mates = tuple(teammates) if self.chooser.coordinated else ()
        if self._recovery > 0:
            self._recovery -= 1
            if self._recovery == 0:
                self._plan(position, grid, mates, reached=False)
            return np.array(RECOVERY_COMMAND)
        self._history.append(position[:2].copy())
        self._since_plan += 1
        if self._is_stuck():
            self._history.clear()
            self._failures += 1
            if self._failures >= MAX_FAILURES and self.target is not None:
                self.blacklist.append(self.target)
                self.target = None
                self._failures = 0
            self._recovery = cfg.recovery_steps
            return np.array(RECOVERY_COMMAND) if self._recovery else np.zeros(2)
        reached = self.follower.done(position) and not self.finished
        if reached or self._since_plan >= cfg.replan_interval:
            self._plan(position, grid, mates, reached=reached)
        if self.finished:
            return np.zeros(2)
        return self.follower.command(position, scan)

    def path_costs(self, points: ArrayLike) -> NDArray[np.float64]:
        """Metres of path from where the robot last planned to ``(K, 2)`` points of its frame.

        From the wavefront of its latest plan (what a teammate is told);
        ``inf`` where it knows no path, and everywhere before its first plan.
        """
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        if self._planning is None or self._wave is None:
            return np.full(len(pts), np.inf)
        resolution = float(np.hypot(*self._planning.cell_to_frame[:2, 0]))
        return self._wave.costs(self._planning.to_cells(pts)) * resolution

    def _is_stuck(self) -> bool:
        """Whether the robot covered less than ``stuck_distance`` over the last
        ``stuck_steps`` steps while having somewhere to go."""
        if len(self._history) < self.config.stuck_steps or self.target is None:
            return False
        trail = np.asarray(self._history)
        travelled = float(np.sum(np.hypot(*np.diff(trail, axis=0).T)))
        return travelled < self.config.stuck_distance

    def _candidates(self, planning: PlanningGrid, wave: Wavefront) -> list[Candidate]:
        """Step 3: the reachable frontier clusters, abandoned targets' surroundings left out."""
        cfg = self.config
        resolution = float(np.hypot(*planning.cell_to_frame[:2, 0]))
        candidates = []
        # The clusters frontier_clusters(planning.state) gives, in its order, compiled.
        grouped, starts = frontier_groups(planning.state)
        for first, last in itertools.pairwise(starts.tolist()):
            if last - first < cfg.min_frontier_size:
                continue
            cells = grouped[first:last]
            points = planning.to_frame(cells)
            if self.blacklist:
                banned = np.zeros(len(cells), dtype=bool)
                for spot in self.blacklist:
                    banned |= np.hypot(*(points - spot).T) <= cfg.blacklist_radius
                cells, points = cells[~banned], points[~banned]
            costs = wave.costs(cells)
            reachable = np.isfinite(costs)
            if np.any(reachable):
                candidates.append(
                    Candidate(
                        cells[reachable],
                        points[reachable],
                        costs[reachable] * resolution,
                        (last - first) * resolution,
                    )
                )
        return candidates

    def _plan(
        self,
        position: NDArray[np.float64],
        grid: OccupancyGrid,
        teammates: tuple[Teammate, ...],
        *,
        reached: bool,
    ) -> None:
        """Steps 1-4: choose a frontier and set the path to it.

        The current target is kept while frontier cells remain within
        ``blacklist_radius`` of it, the robot has not yet reached it and no
        nearer teammate has taken it; a target reached that is still a
        frontier cannot be resolved from there and is abandoned.
        """
        cfg = self.config
        self._since_plan = 0
        planning = planning_grid(grid, cfg.planner)
        start = _start_cell(planning, position[:2], cfg.start_search_radius)
        if start is None:
            self._recovery = cfg.recovery_steps
            return
        wave = Wavefront(planning, start)
        self._planning, self._wave = planning, wave
        candidates = self._candidates(planning, wave)
        choice = self._keep_target(candidates, wave, teammates, position, reached)
        if choice is None:
            picked = self.chooser.choose(candidates, teammates, size_bonus=cfg.size_bonus)
            if picked is not None:
                cell = candidates[picked[0]].cells[picked[1]]
                choice = (int(cell[0]), int(cell[1]))
            self._failures = 0
        if choice is None:
            self.finished = True
            self.target = None
            self.follower.set_path(np.zeros((0, 2)))
            return
        self.finished = False
        self.target = planning.to_frame([choice])[0]
        self.follower.set_path(planning.to_frame(wave.path(choice)))

    def _keep_target(
        self,
        candidates: list[Candidate],
        wave: Wavefront,
        teammates: tuple[Teammate, ...],
        position: NDArray[np.float64],
        reached: bool,
    ) -> tuple[int, int] | None:
        """The frontier cell nearest the current target if the target still holds."""
        if self.target is None:
            return None
        near_cells = [
            c.cells[np.hypot(*(c.points - self.target).T) <= self.config.blacklist_radius]
            for c in candidates
        ]
        near = np.concatenate(near_cells) if near_cells else np.zeros((0, 2), dtype=np.intp)
        if len(near) == 0:
            return None
        if reached:
            self.blacklist.append(self.target)
            return None
        if self._yields(teammates, position):
            return None
        costs = wave.costs(near)
        index = int(np.argmin(costs))
        return (int(near[index, 0]), int(near[index, 1]))

    def _yields(self, teammates: tuple[Teammate, ...], position: NDArray[np.float64]) -> bool:
        """Whether a teammate strictly nearer to the current target (straight line, from
        where each pose estimate puts it) has taken one within ``claim_radius`` of it."""
        assert self.target is not None
        mine = float(np.hypot(*(self.target - position[:2])))
        for mate in teammates:
            if mate.target is None:
                continue
            if float(np.hypot(*(mate.target - self.target))) > self.config.claim_radius:
                continue
            theirs = float(np.hypot(*(mate.target - mate.position)))
            if theirs < mine:
                return True
        return False
