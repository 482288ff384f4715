"""Worlds robots explore: the generated office floor and worlds made from real maps.

>>> from tomosim.worlds import generate_floorplan
>>> world = generate_floorplan(7)
>>> world.walls.shape[1:], world.truth.resolution
((2, 2), 0.05)
"""

from tomosim.worlds.floorplan import generate_floorplan
from tomosim.worlds.floorplan_config import FloorplanConfig
from tomosim.worlds.from_map import walls_from_mask, world_from_grid, world_from_map
from tomosim.worlds.world import World

__all__ = [
    "FloorplanConfig",
    "World",
    "generate_floorplan",
    "walls_from_mask",
    "world_from_grid",
    "world_from_map",
]
