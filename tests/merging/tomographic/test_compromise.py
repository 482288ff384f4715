"""The best rigid compromise for maps that bend against each other."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from merging.evidence.refine import SmoothedMap, constraint_strength
from merging.evidence.verify import prepare_map
from merging.params import DEFAULT_PARAMS
from merging.tomographic.candidates import SearchMaps, rms_between
from merging.tomographic.judging import with_compromise_curvature
from merging.tomographic.restarts import rigid_compromise
from merging.transforms import matrix_to_pose, rigid_matrix
from tests.merging.builders import synthetic_building


def _maps(first: np.ndarray, second: np.ndarray) -> SearchMaps:
    params = DEFAULT_PARAMS
    return SearchMaps(
        prepare_map(first, params=params.verify), prepare_map(second, params=params.verify), params
    )


def test_maps_that_do_not_bend_keep_their_placement() -> None:
    grid = synthetic_building(6)
    moved, distance = rigid_compromise(_maps(grid, grid), np.eye(3))
    assert distance < 0.5
    assert np.allclose(matrix_to_pose(moved)[:2], 0.0, atol=0.5)


def test_a_bent_map_settles_between_its_parts() -> None:
    # Map 2 is map 1 with its right half drawn 4 cells lower: the identity fits the
    # left half exactly, a shift of 4 cells up the right half. The compromise lies
    # between the two (it may turn a little to fit both), nearer each than they are
    # to each other.
    grid = synthetic_building(6)
    bent = grid.copy()
    half = grid.shape[1] // 2
    bent[4:, half:] = grid[:-4, half:]
    bent[:4, half:] = -1
    maps = _maps(grid, bent)
    moved, distance = rigid_compromise(maps, np.eye(3))
    right_half_fit = rigid_matrix(0.0, -4.0, 0.0)  # (x, y) = (col, row): 4 rows up
    to_right = rms_between(moved, right_half_fit, maps.second.points)
    assert 0.5 < distance < 3.5
    assert 0.5 < to_right < 3.5


def test_a_compromise_has_its_curvature_measured_on_its_fields_too() -> None:
    # The robust evidence's strength widths gain the compromise's; nothing else changes,
    # the walls' tolerance included.
    params = with_compromise_curvature(DEFAULT_PARAMS)
    default, sigmas = DEFAULT_PARAMS.robust, DEFAULT_PARAMS.compromise.sigmas
    assert set(params.robust.strength_widths) == {*default.strength_widths, *sigmas}
    assert max(params.robust.strength_widths) > max(default.strength_widths)
    assert replace(params.robust, strength_widths=default.strength_widths) == default
    assert replace(params, robust=default) == DEFAULT_PARAMS


def _corridor(cross_wall: bool) -> np.ndarray:
    """Two parallel walls 600 cells long, 20 apart, and at column 300 a wall across them."""
    grid = np.full((60, 600), -1, dtype=np.int8)
    grid[3:57, 3:597] = 0
    grid[20, 3:597] = grid[40, 3:597] = 100
    if cross_wall:
        grid[20:41, 300] = 100
    return grid


def test_a_corridor_that_lets_the_maps_slide_stays_weak_on_the_compromise_fields() -> None:
    # Map 2 is the middle of the corridor: slid along it, its walls stay on map 1's at
    # every field width, so the widest strength the robust evidence measures for a
    # compromise stays below its threshold; a wall across the corridor holds it.
    params = with_compromise_curvature(DEFAULT_PARAMS)
    placement = rigid_matrix(150.0, 0.0, 0.0)

    def widest_strength(grid: np.ndarray) -> float:
        first, second = prepare_map(grid), prepare_map(grid[:, 150:450])
        smoothed = SmoothedMap(first.walls, first.shape)
        strengths = []
        for width in params.robust.strength_widths:
            field = replace(params.gauss_newton, curvature_sigma=width, curvature_step=width)
            strength = constraint_strength(smoothed, second, placement, local=True, params=field)
            strengths.append(strength * width**2)
        return max(strengths)

    assert widest_strength(_corridor(cross_wall=False)) < params.robust.strength
    assert widest_strength(_corridor(cross_wall=True)) > params.robust.strength
