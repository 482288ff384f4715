"""The best rigid compromise for maps that bend against each other."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

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
