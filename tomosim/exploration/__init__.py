"""Frontier-based exploration: frontiers, planning on known free space, path following.

>>> from tomosim.exploration import FrontierPolicy
>>> policy = FrontierPolicy()  # policy.act(pose, grid, scan=scan) -> (linear, angular)
"""

from tomosim.exploration.controller import ControllerConfig, PathFollower
from tomosim.exploration.frontiers import Frontier, coarsen, frontier_clusters, frontier_mask
from tomosim.exploration.planning import PlannerConfig, PlanningGrid, Wavefront, planning_grid
from tomosim.exploration.policy import ExplorationConfig, FrontierPolicy

__all__ = [
    "ControllerConfig",
    "ExplorationConfig",
    "Frontier",
    "FrontierPolicy",
    "PathFollower",
    "PlannerConfig",
    "PlanningGrid",
    "Wavefront",
    "coarsen",
    "frontier_clusters",
    "frontier_mask",
    "planning_grid",
]
