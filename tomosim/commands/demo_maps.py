"""The demo pair of ``tomosim merge --demo``: two robots' views of one generated floor plan.

Both maps are cut from the ground-truth grid of
:func:`tomosim.worlds.generate_floorplan` with the protocol of section 4.1 of
the paper (:func:`merging.evaluation.pairs.cut_window_pairs`): two overlapping windows,
the second rotated by a random angle and shifted, so the true transform
between them is known.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from merging import OccupancyGrid
from merging.evaluation.pairs import cut_window_pairs
from tomosim.worlds import generate_floorplan

DEMO_SEED = 0
"""Floor plan and window seed of ``--demo`` without a value."""
DEMO_OVERLAP = (0.5, 0.9)
"""Average overlap ratio of the demo windows: enough shared walls for a clear merge."""
DEMO_SIZE_FRACTION = (0.55, 0.75)
"""Window sides as fractions of the floor plan's observed extent."""


def demo_pair(seed: int) -> tuple[OccupancyGrid, OccupancyGrid, NDArray[np.float64]]:
    """Two overlapping maps of floor plan ``seed`` and the true map 2 -> map 1 cell transform.

    Both maps have the floor plan's resolution and origin ``(0, 0, 0)``: each is
    in its own robot's frame. The same seed draws the windows, angle and shift.
    """
    world = generate_floorplan(seed)
    truth_grid = world.truth
    pair = cut_window_pairs(
        truth_grid.data,
        count=1,
        size_fraction=DEMO_SIZE_FRACTION,
        overlap_range=DEMO_OVERLAP,
        rng=seed,
    )[0]
    resolution = truth_grid.resolution
    map1 = OccupancyGrid(pair.map1, resolution=resolution)
    map2 = OccupancyGrid(pair.map2, resolution=resolution)
    return map1, map2, pair.truth
