"""Frontier-based exploration: frontiers, planning on known free space, target choice,
path following, and a team of such robots.

>>> from tomosim.exploration import FrontierPolicy, TeamExplorer
>>> policy = FrontierPolicy()  # policy.act(pose, grid, scan=scan) -> (linear, angular)
>>> team = TeamExplorer(3, policy="utility")  # team.act(session) -> (3, 2) commands
"""

from tomosim.exploration.choosers import CHOOSERS, chooser_names, make_chooser
from tomosim.exploration.controller import ControllerConfig, PathFollower
from tomosim.exploration.frontiers import Frontier, coarsen, frontier_clusters, frontier_mask
from tomosim.exploration.planning import PlannerConfig, PlanningGrid, Wavefront, planning_grid
from tomosim.exploration.policy import ExplorationConfig, FrontierPolicy
from tomosim.exploration.targets import Candidate, TargetChooser, Teammate
from tomosim.exploration.team import DEFAULT_POLICY, TeamExplorer

__all__ = [
    "CHOOSERS",
    "DEFAULT_POLICY",
    "Candidate",
    "ControllerConfig",
    "ExplorationConfig",
    "Frontier",
    "FrontierPolicy",
    "PathFollower",
    "PlannerConfig",
    "PlanningGrid",
    "TargetChooser",
    "TeamExplorer",
    "Teammate",
    "Wavefront",
    "chooser_names",
    "coarsen",
    "frontier_clusters",
    "frontier_mask",
    "make_chooser",
    "planning_grid",
]
