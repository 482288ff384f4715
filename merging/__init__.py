"""Occupancy-grid map merging with tomographic (Radon-transform) features.

``merging`` is usable on its own: it imports neither the simulator nor the
environments.

Two maps of one room, the second seen from 7 cells left of and 3 cells below
the first (grids in the ROS coding: -1 unknown, 0 free, 100 occupied):

>>> import numpy as np
>>> import merging
>>> room = np.full((100, 140), -1, dtype=np.int8)
>>> room[10:90, 10:130] = 0                        # free space
>>> room[[10, 89], 10:130] = room[10:90, [10, 129]] = 100  # outer walls
>>> room[10:60, 50] = room[40, 50:100] = room[60:90, 95] = 100  # inner walls
>>> seen = np.full_like(room, -1)
>>> seen[3:, 7:] = room[:-3, :-7]
>>> result = merging.estimate_transform(room, seen)
>>> x, y, theta = merging.matrix_to_pose(result.matrix)  # seen's cells -> room's cells
>>> round(x), round(y), round(theta, 3), result.accepted
(-7, -3, 0.0, True)
"""

from merging.api import available_methods, check_method, estimate_transform, register_method
from merging.evaluation.metrics import acceptance_index, matching_index, transform_error
from merging.grid import (
    FREE_THRESHOLD,
    OCCUPIED_THRESHOLD,
    OccupancyGrid,
    validate_cells,
)
from merging.linking import FusedMap, Linking, MergeAllResult, fuse, link_maps, merge, merge_all
from merging.mapio import load_map, save_map
from merging.result import Hypothesis, MergeResult
from merging.transforms import cells_to_metres, matrix_to_pose, rigid_matrix

__all__ = [
    "FREE_THRESHOLD",
    "OCCUPIED_THRESHOLD",
    "FusedMap",
    "Hypothesis",
    "Linking",
    "MergeAllResult",
    "MergeResult",
    "OccupancyGrid",
    "acceptance_index",
    "available_methods",
    "cells_to_metres",
    "check_method",
    "estimate_transform",
    "fuse",
    "link_maps",
    "load_map",
    "matching_index",
    "matrix_to_pose",
    "merge",
    "merge_all",
    "register_method",
    "rigid_matrix",
    "save_map",
    "transform_error",
    "validate_cells",
]

# Registering the methods: importing a module adds it to the registry.
from merging import paper as _paper  # noqa: F401
from merging import tomographic as _tomographic  # noqa: F401
from merging.baselines import features as _features  # noqa: F401
from merging.baselines import registration as _registration  # noqa: F401
from merging.baselines import ros as _ros  # noqa: F401
from merging.baselines import spectral as _spectral  # noqa: F401
