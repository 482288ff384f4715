"""A team's exploration: one frontier policy per robot, coordinated through what each knows.

:class:`TeamExplorer` turns a :class:`~tomosim.team.TeamSession` into the
robots' commands for one step. Robot ``k`` acts on its pose estimate and its
best map (:meth:`TeamSession.best_map <tomosim.team.TeamSession.best_map>`),
and, when its chooser coordinates, on what it knows of its *contacts*
(:meth:`TeamSession.contacts <tomosim.team.TeamSession.contacts>`): the
teammates its map is linked to by accepted merges and that it can talk to
now. Each contact's pose estimate, current target and path costs are carried
into robot ``k``'s frame by the merge transform (:class:`Teammate`). A robot
with no contacts explores alone.

Robots act in index order within a step, so a robot that replans sees the
targets its contacts of lower index chose in the same step.

>>> from tomosim.exploration import TeamExplorer
>>> explorer = TeamExplorer(3)  # explorer.act(session) -> (3, 2) commands
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from merging.validators import whole_number
from tomosim.exploration.choosers import make_chooser
from tomosim.exploration.policy import ExplorationConfig, FrontierPolicy
from tomosim.exploration.targets import PathCosts, Teammate

if TYPE_CHECKING:
    from tomosim.team.session import TeamSession

DEFAULT_POLICY = "utility"
"""The exploration policy of ``tomosim explore``, sweeps and the environment's
scripted baseline: the fastest to 90 % coverage in ``scripts/study_exploration.py``."""


def _carry(matrix: NDArray[np.float64], point: NDArray[np.float64]) -> NDArray[np.float64]:
    """A 2-D point through a 3x3 rigid matrix."""
    return np.asarray(matrix[:2, :2] @ point[:2] + matrix[:2, 2], dtype=np.float64)


def _carried_costs(policy: FrontierPolicy, into_mate: NDArray[np.float64]) -> PathCosts:
    """``policy``'s path costs, asked with points of another robot's frame."""

    def costs(points: NDArray[np.float64]) -> NDArray[np.float64]:
        local = np.asarray(points, dtype=float) @ into_mate[:2, :2].T + into_mate[:2, 2]
        return policy.path_costs(local)

    return costs


class TeamExplorer:
    """Frontier exploration for a whole team (module docstring).

    Parameters
    ----------
    robots : int
        Team size.
    policy : str
        The target chooser of every robot (:func:`~tomosim.exploration.choosers.chooser_names`).
    config : ExplorationConfig, optional
        Planning, following and choosing parameters, shared by all robots.
    """

    __slots__ = ("policies", "policy")

    def __init__(
        self, robots: int, *, policy: str = DEFAULT_POLICY, config: ExplorationConfig | None = None
    ) -> None:
        whole_number(robots, "robots", minimum=1)
        make_chooser(policy)  # one clear error for an unknown name
        self.policy = policy
        self.policies = [FrontierPolicy(config, chooser=policy) for _ in range(int(robots))]

    @property
    def finished(self) -> bool:
        """Whether no robot has a reachable frontier left."""
        return all(policy.finished for policy in self.policies)

    def teammates(self, session: TeamSession, robot: int) -> list[Teammate]:
        """What ``robot`` knows of its contacts, in its own frame (module docstring)."""
        mates = []
        for other, into_robot in sorted(session.contacts(robot).items()):
            policy = self.policies[other]
            pose = session.simulation.odometry[other].pose
            target = None if policy.target is None else _carry(into_robot, policy.target)
            mates.append(
                Teammate(
                    robot=other,
                    position=_carry(into_robot, pose),
                    target=target,
                    path_costs=_carried_costs(
                        policy, np.asarray(np.linalg.inv(into_robot), np.float64)
                    ),
                )
            )
        return mates

    def act(self, session: TeamSession) -> NDArray[np.float64]:
        """The ``(N, 2)`` normalised commands of every robot for the next step."""
        if session.count != len(self.policies):
            raise ValueError(
                f"the session has {session.count} robots, the explorer {len(self.policies)}"
            )
        sim = session.simulation
        commands = np.zeros((session.count, 2))
        for k, policy in enumerate(self.policies):
            mates = self.teammates(session, k) if policy.chooser.coordinated else []
            commands[k] = policy.act(
                sim.odometry[k].pose, session.best_map(k), scan=sim.scans[k], teammates=mates
            )
        return commands
