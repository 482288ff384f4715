"""The figures exploration papers report, followed step by step.

:class:`ExplorationTracker` reads a :class:`~tomosim.team.TeamSession` after
every step and keeps

* the team's coverage of the free space and each robot's own (what its own
  grid knows, :meth:`TeamCoverage.robot_fraction
  <tomosim.team.TeamCoverage.robot_fraction>`);
* each robot's path length: the metres its true position moved, summed over
  steps;
* the *overlap rate*: the sum of what each robot knows over what the team
  knows, less one (0 when no two robots know the same cell, ``N - 1`` when
  all ``N`` know the same), the multi-robot measure of redundant work of
  Explore-Bench [1]_.

These use the simulator's truth (true poses, the coverage rule); the robots
never see them.

References
----------
.. [1] Y. Xu et al., "Explore-Bench: Data Sets, Metrics and Evaluations for
   Frontier-based and Deep-reinforcement-learning-based Autonomous
   Exploration", ICRA 2022.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from tomosim.team.session import TeamSession


def overlap_rate(robot_coverage: NDArray[np.float64] | tuple[float, ...], team: float) -> float:
    """``sum(robot_coverage) / team - 1``; 0 while the team knows nothing.

    Never below 0: the team knows the union of what the robots know, so the sum is at
    least the team's, and a rounding below it once printed as "-0.00".
    """
    return max(float(np.sum(robot_coverage)) / team - 1.0, 0.0) if team > 0 else 0.0


@dataclass(frozen=True, slots=True)
class StepFigures:
    """The tracked figures after one step.

    Attributes
    ----------
    step : int
    team_coverage : float
        Fraction of the free space the team knows.
    robot_coverage : tuple of float
        Per robot, the fraction its own grid knows.
    path_lengths : tuple of float
        Per robot, metres travelled so far.
    overlap_rate : float
        :func:`overlap_rate` of the two coverages.
    """

    step: int
    team_coverage: float
    robot_coverage: tuple[float, ...]
    path_lengths: tuple[float, ...]
    overlap_rate: float

    @property
    def path_length(self) -> float:
        """Metres travelled by the whole team."""
        return float(sum(self.path_lengths))


class ExplorationTracker:
    """Follows a session's coverage and path lengths (module docstring).

    Parameters
    ----------
    session : TeamSession
        The session, before its first step (its state then is step 0).

    Attributes
    ----------
    team_curve : list of float
        Team coverage after each step, from step 0.
    """

    __slots__ = ("_figures", "_last", "_paths", "_robot_rows", "_step", "team_curve")

    def __init__(self, session: TeamSession) -> None:
        self._last = session.simulation.true_poses[:, :2]
        self._paths = np.zeros(session.count)
        self.team_curve: list[float] = []
        self._robot_rows: list[NDArray[np.float64]] = []  # per step, each robot's coverage
        self._step = session.steps
        self._figures: StepFigures | None = None
        self.advance(session, moved=False)

    def update(self, session: TeamSession, *, moved: bool = True) -> StepFigures:
        """Take in the session after a step; returns the step's figures."""
        self.advance(session, moved=moved)
        return self.last

    def advance(self, session: TeamSession, *, moved: bool = True) -> None:
        """:meth:`update` without building the step's figures (``last`` builds them when
        asked): what a caller that wants them only at the end takes in at every step."""
        if moved:
            now = session.simulation.true_poses[:, :2]
            travel = now - self._last
            self._paths += np.hypot(travel[:, 0], travel[:, 1])
            self._last = now
        coverage = session.coverage
        self.team_curve.append(coverage.fraction)
        self._robot_rows.append(coverage.robot_fractions())
        self._step = session.steps
        self._figures = None

    @property
    def last(self) -> StepFigures:
        """The figures of the latest step."""
        if self._figures is None:
            robots = self._robot_rows[-1]
            team = self.team_curve[-1]
            self._figures = StepFigures(
                step=self._step,
                team_coverage=team,
                robot_coverage=tuple(robots.tolist()),
                path_lengths=self.path_lengths,
                overlap_rate=overlap_rate(robots, team),
            )
        return self._figures

    @property
    def robot_curves(self) -> list[list[float]]:
        """Per robot, its own coverage after each step, from step 0 (new lists each call)."""
        rows = (row.tolist() for row in self._robot_rows)
        return [list(curve) for curve in zip(*rows, strict=True)]

    @property
    def path_lengths(self) -> tuple[float, ...]:
        """Per robot, metres travelled so far."""
        return tuple(self._paths.tolist())
