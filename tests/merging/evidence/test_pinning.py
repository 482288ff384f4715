"""What moving a placement costs: sliding (ray consistency) and turning (curvature)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import merging
from merging.evidence.pinning import lever_arm, pinning
from merging.evidence.refine import SmoothedMap, constraint_strength, turning_strength
from merging.evidence.verdict import LEVER_REASON
from merging.evidence.verify import prepare_map
from merging.params import DEFAULT_PARAMS
from merging.transforms import rigid_matrix
from tests.merging.builders import synthetic_building


def _room(shape: tuple[int, int], walls: list[tuple[slice, slice]]) -> np.ndarray:
    """Free space with the given occupied slices, unknown at the border."""
    grid = np.zeros(shape, dtype=np.int8)
    grid[:3, :] = grid[-3:, :] = -1
    grid[:, :3] = grid[:, -3:] = -1
    for rows, cols in walls:
        grid[rows, cols] = 100
    return grid


CORRIDOR = [(slice(20, 21), slice(3, 197)), (slice(40, 41), slice(3, 197))]
"""Two long parallel walls, 20 cells apart."""


def test_a_cross_wall_pins_a_corridor() -> None:
    # Along a corridor with nothing across it, sliding costs only the walls' ends,
    # which slide off the map; closed by a wall across it, sliding takes that wall's
    # 21 cells off their twins in each map.
    corridor = prepare_map(_room((60, 200), CORRIDOR))
    closed = prepare_map(_room((60, 200), [*CORRIDOR, (slice(20, 41), slice(100, 101))]))
    open_cost = pinning(corridor, corridor, np.eye(3))
    closed_cost = pinning(closed, closed, np.eye(3))
    assert open_cost <= 4 * 2 * 2  # 2 cells at each of 4 ends, both maps
    assert closed_cost >= open_cost + 2 * 15


def test_a_placement_off_the_truth_gains_by_moving() -> None:
    grid = synthetic_building(6)
    prepared = prepare_map(grid)
    off = rigid_matrix(3.0, 0.0, 0.0)
    assert pinning(prepared, prepared, off) < 0.0


@pytest.mark.parametrize("seed", [3, 6])
def test_turning_is_held_at_least_as_firmly_as_the_weakest_direction(seed: int) -> None:
    # The turn with its following translation is one direction of motion; the
    # constraint strength is the least over all of them (a Rayleigh quotient bound).
    grid = synthetic_building(seed)
    first, second = prepare_map(grid), prepare_map(grid[40:200, 60:260])
    smoothed = SmoothedMap(first.walls, first.shape)
    truth = rigid_matrix(60.0, 40.0, 0.0)
    turn = turning_strength(smoothed, second, truth)
    weakest = constraint_strength(smoothed, second, truth)
    assert turn >= weakest - 1e-6
    assert turn > 0.0


def test_lever_arm_is_one_when_every_wall_meets() -> None:
    building = prepare_map(synthetic_building(3))
    assert lever_arm(building, building, np.eye(3)) == pytest.approx(1.0)


def test_lever_arm_grows_as_the_overlap_shrinks() -> None:
    # Map 1 holds the left part of map 2's building; the less it holds, the farther map
    # 2's walls reach from where the two meet.
    grid = synthetic_building(3)
    whole = prepare_map(grid)
    levers = []
    for width in (300, 180, 90):
        part = grid.copy()
        part[:, width:] = -1
        levers.append(lever_arm(prepare_map(part), whole, np.eye(3)))
    assert 1.0 < levers[0] < levers[1] < levers[2]


def test_a_close_fit_reaching_too_far_is_refused_and_says_why() -> None:
    grid = synthetic_building(3)
    part = grid.copy()
    part[:, 180:] = -1
    assert merging.estimate_transform(part, grid).accepted
    confidence = replace(DEFAULT_PARAMS.confidence, max_lever=1.01)
    strict = replace(DEFAULT_PARAMS, confidence=confidence)
    result = merging.estimate_transform(part, grid, params=strict)
    assert not result.accepted
    assert result.reason == LEVER_REASON
    assert result.evidence["lever_arm"] > 1.01
