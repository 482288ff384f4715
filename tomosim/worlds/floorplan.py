"""The built-in world: a seeded, procedurally generated office floor.

:func:`generate_floorplan` draws a plan (:mod:`tomosim.worlds.layout`),
paints it into a truth grid (walls of ``wall_thickness``, unknown outside the
building), adds furniture that never cuts the free space apart for a robot,
and outlines the walls with :func:`~tomosim.worlds.from_map.world_from_grid`,
so that the segments robots collide with and the lidar sees bound exactly the
occupied cells of the truth grid.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from merging.grid import FREE, OCCUPIED, UNKNOWN, OccupancyGrid
from merging.validators import as_generator
from tomosim.worlds.floorplan_config import FloorplanConfig
from tomosim.worlds.from_map import world_from_grid
from tomosim.worlds.layout import Layout, draw_layout
from tomosim.worlds.paint import box_mask, paint_rectangle
from tomosim.worlds.world import World

AXIS_ALIGNED_PROBABILITY = 0.6
"""Chance that a piece of furniture is parallel to the walls (else at a random angle)."""
DOOR_KEEP_OUT = 1.0
"""Metres kept free of furniture around each door's centre (beyond the piece's half diagonal)."""
MIN_POCKET_AREA = 0.25
"""Square metres below which a separate patch of robot-reachable space is ignored
when checking that furniture keeps the floor connected."""
EIGHT_CONNECTED = np.ones((3, 3), dtype=bool)


def generate_floorplan(
    seed: int | np.random.Generator | None = None,
    *,
    width: float | None = None,
    height: float | None = None,
    resolution: float | None = None,
    config: FloorplanConfig | None = None,
) -> World:
    """Generate an office floor plan (rooms, corridors, doors, furniture).

    Parameters
    ----------
    seed : int, numpy.random.Generator or None
        The same integer seed always gives the same world.
    width, height : float, optional
        Size of the building in metres (default 30 x 20); override ``config``.
    resolution : float, optional
        Truth-grid cell size in metres (default 0.05); overrides ``config``.
    config : FloorplanConfig, optional
        Every other parameter of the generator.

    Returns
    -------
    World
        Building frame: the building's bounding box spans ``[0, width] x
        [0, height]`` metres; the truth grid adds ``config.margin`` of unknown
        cells around it.
    """
    base = config if config is not None else FloorplanConfig()
    if not isinstance(base, FloorplanConfig):
        raise TypeError(f"config must be a FloorplanConfig, got {type(base).__name__}")
    cfg = dataclasses.replace(
        base,
        width=base.width if width is None else float(width),
        height=base.height if height is None else float(height),
        resolution=base.resolution if resolution is None else float(resolution),
    )
    rng = as_generator(seed, name="seed")
    layout = draw_layout(cfg, rng)
    grid = OccupancyGrid(
        np.zeros((1, 1), dtype=np.int8),
        resolution=cfg.resolution,
        origin=(-cfg.margin, -cfg.margin, 0.0),
    )
    cols = math.ceil((cfg.width + 2 * cfg.margin) / cfg.resolution)
    rows = math.ceil((cfg.height + 2 * cfg.margin) / cfg.resolution)
    data = paint_layout(layout, (rows, cols), grid, cfg)
    place_clutter(data, layout, grid, cfg, rng)
    truth = OccupancyGrid(data, resolution=cfg.resolution, origin=grid.origin)
    label = seed if isinstance(seed, int | np.integer) else "random"
    return world_from_grid(truth, name=f"floorplan seed={label}")


def paint_layout(
    layout: Layout, shape: tuple[int, int], grid: OccupancyGrid, config: FloorplanConfig
) -> NDArray[np.int8]:
    """Paint ``layout`` into a new ``int8`` array: building free, walls occupied,
    outside unknown. ``grid`` gives the resolution and origin."""
    data = np.full(shape, UNKNOWN, dtype=np.int8)
    paint_rectangle(data, grid, layout.outline, FREE)
    if layout.notch is not None:
        paint_rectangle(data, grid, layout.notch, UNKNOWN)
    # The outer wall straddles the building's boundary: cells whose centres lie
    # within half a wall thickness of it, inside or out (an edge lies half a
    # cell from the centres of the cells beside it).
    inside = data == FREE
    reach = 0.5 * config.wall_thickness / config.resolution + 0.5
    outer = (ndimage.distance_transform_edt(inside) <= reach) & inside
    outer |= (ndimage.distance_transform_edt(~inside) <= reach) & ~inside
    data[outer] = OCCUPIED
    half = 0.5 * config.wall_thickness
    for x0, y0, x1, y1 in layout.rooms:
        for wall in (
            (x0 - half, y0 - half, x1 + half, y0 + half),
            (x0 - half, y1 - half, x1 + half, y1 + half),
            (x0 - half, y0 - half, x0 + half, y1 + half),
            (x1 - half, y0 - half, x1 + half, y1 + half),
        ):
            paint_rectangle(data, grid, wall, OCCUPIED)
    for block in layout.solid:
        paint_rectangle(data, grid, block, OCCUPIED)
    for door in layout.doors:
        paint_rectangle(data, grid, door, FREE)
    return data


def _connected(roomy: NDArray[np.bool_], min_cells: int) -> bool:
    """Whether at most one 8-connected patch of ``roomy`` has ``min_cells`` or more cells."""
    return _patches(roomy, min_cells) <= 1


def _patches(roomy: NDArray[np.bool_], min_cells: int) -> int:
    """The 8-connected patches of ``roomy`` of ``min_cells`` or more cells."""
    labels, count = ndimage.label(roomy, structure=EIGHT_CONNECTED)
    if count == 0:
        return 0
    sizes = np.bincount(labels.ravel())[1:]
    return int(np.count_nonzero(sizes >= min_cells))


def _out_of_reach(
    reach: NDArray[np.bool_], footprint: NDArray[np.bool_], radius_cells: float
) -> NDArray[np.bool_]:
    """``reach`` less the cells within ``radius_cells`` of ``footprint`` (the centres a disc
    of that radius can take once the footprint is a wall), computed around it only."""
    rows, cols = np.nonzero(footprint)
    if len(rows) == 0:
        return reach
    pad = math.ceil(radius_cells) + 1
    r0, r1 = max(rows.min() - pad, 0), min(rows.max() + pad + 1, reach.shape[0])
    c0, c1 = max(cols.min() - pad, 0), min(cols.max() + pad + 1, reach.shape[1])
    near = ndimage.distance_transform_edt(~footprint[r0:r1, c0:c1]) <= radius_cells
    out = reach.copy()
    out[r0:r1, c0:c1] &= ~near
    return out


def place_clutter(
    data: NDArray[np.int8],
    layout: Layout,
    grid: OccupancyGrid,
    config: FloorplanConfig,
    rng: np.random.Generator,
) -> None:
    """Add furniture (boxes) to the rooms of ``data`` in place.

    A piece is dropped when it would come within :data:`DOOR_KEEP_OUT` of a
    door or split the space reachable by a disc of ``config.robot_clearance``
    into separate patches (of at least :data:`MIN_POCKET_AREA`). That is judged
    twice: quickly, with the piece's box grown by the clearance (which decides
    which pieces a floor gets), and exactly, on the cells the piece paints, for
    the pockets the grown box misses where a rotated piece meets a corner.
    """
    res = config.resolution
    clearance = config.robot_clearance
    roomy = ndimage.distance_transform_edt(data == FREE) * res > clearance
    min_cells = max(1, round(MIN_POCKET_AREA / res**2))
    fits = roomy.copy()  # exactly where the disc's centre fits, piece by piece
    patches = _patches(fits, min_cells)
    doors = np.array([[0.5 * (d[0] + d[2]), 0.5 * (d[1] + d[3])] for d in layout.doors])
    half_wall = 0.5 * config.wall_thickness
    for x0, y0, x1, y1 in layout.rooms:
        count = int(rng.integers(config.clutter_per_room[0], config.clutter_per_room[1] + 1))
        for _ in range(count):
            length = rng.uniform(*config.clutter_length)
            width = min(rng.uniform(*config.clutter_width), length)
            if rng.random() < AXIS_ALIGNED_PROBABILITY:
                angle = 0.5 * np.pi * float(rng.integers(2))
            else:
                angle = rng.uniform(0.0, np.pi)
            c, s = abs(math.cos(angle)), abs(math.sin(angle))
            ex, ey = 0.5 * (length * c + width * s), 0.5 * (length * s + width * c)
            low_x, high_x = x0 + half_wall + ex, x1 - half_wall - ex
            low_y, high_y = y0 + half_wall + ey, y1 - half_wall - ey
            if high_x <= low_x or high_y <= low_y:
                continue
            centre = np.array([rng.uniform(low_x, high_x), rng.uniform(low_y, high_y)])
            reach = DOOR_KEEP_OUT + 0.5 * math.hypot(length, width)
            if len(doors) and np.min(np.hypot(*(doors - centre).T)) < reach:
                continue
            box = (float(centre[0]), float(centre[1]), length, width, angle)
            grow = 2 * (clearance + res)
            grown = box_mask(data.shape, grid, (box[0], box[1], length + grow, width + grow, angle))
            candidate = roomy & ~grown
            if not _connected(candidate, min_cells):
                continue
            footprint = box_mask(data.shape, grid, box) & (data == FREE)
            still_fits = _out_of_reach(fits, footprint, clearance / res)
            now = _patches(still_fits, min_cells)
            if now > patches:
                continue
            data[footprint] = OCCUPIED
            roomy, fits, patches = candidate, still_fits, now
