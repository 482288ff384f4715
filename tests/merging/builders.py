"""Grids the merger's tests build: a synthetic building and pairs no method can merge."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from merging.transforms import rigid_matrix
from merging.warp import warp_cells


def synthetic_building(seed: int, shape: tuple[int, int] = (260, 360)) -> NDArray[np.int8]:
    """A seeded, non-symmetric floor plan in the ROS coding, for tests.

    An outer wall around free space (unknown outside), interior walls at
    random places with door gaps, a slanted wall and a few boxes: enough
    structure in every direction that the transform is unique.
    """
    rng = np.random.default_rng(seed)
    rows, cols = shape
    grid = np.full(shape, -1, dtype=np.int8)
    grid[10 : rows - 10, 10 : cols - 10] = 0
    grid[10, 10 : cols - 10] = grid[rows - 11, 10 : cols - 10] = 100
    grid[10 : rows - 10, 10] = grid[10 : rows - 10, cols - 11] = 100
    for _ in range(4):
        x = int(rng.integers(40, cols - 40))
        grid[10 : rows - 10, x] = 100
        door = int(rng.integers(20, rows - 40))
        grid[door : door + 14, x] = 0
    for _ in range(3):
        y = int(rng.integers(40, rows - 40))
        x0 = int(rng.integers(10, cols // 2))
        grid[y, x0 : x0 + int(rng.integers(60, cols // 2))] = 100
    for t in range(80):
        grid[30 + t // 2, 40 + t] = 100
    for _ in range(6):
        y, x = int(rng.integers(20, rows - 30)), int(rng.integers(20, cols - 30))
        h, w = (int(v) for v in rng.integers(3, 9, size=2))
        grid[y : y + h, x : x + w] = 100
    return grid


UNMERGEABLE_CASES = ("empty", "all unknown", "single wall", "no overlap")
"""Valid grid pairs that no method can merge; every method must refuse them."""


def unmergeable_pair(case: str) -> tuple[NDArray[np.int8], NDArray[np.int8]]:
    """The pair of grids named by ``case`` (one of :data:`UNMERGEABLE_CASES`)."""
    rng = np.random.default_rng(4)
    free = np.zeros((80, 90), dtype=np.int8)
    if case == "empty":
        return free, free
    if case == "all unknown":
        return np.full((50, 50), -1, np.int8), np.full((60, 40), -1, np.int8)
    if case == "single wall":
        wall = free.copy()
        wall[40, 5:85] = 100
        return wall, wall[::-1, ::-1].copy()
    if case == "no overlap":
        a = np.where(rng.random((80, 90)) < 0.04, 100, 0).astype(np.int8)
        b = np.where(rng.random((70, 60)) < 0.04, 100, 0).astype(np.int8)
        return a, b
    raise ValueError(f"unknown case {case!r}; choose from {UNMERGEABLE_CASES}")


def turned(grid: np.ndarray, degrees: float, shift: tuple[float, float]):
    """``grid`` turned counter-clockwise by ``degrees`` about its centre and shifted.

    Returns the new grid and the true matrix taking its cells back to ``grid``'s.
    """
    theta = np.deg2rad(degrees)
    rows, cols = grid.shape
    size = int(np.ceil(np.hypot(rows, cols))) + 40
    centre_in = np.array([(cols - 1) / 2, (rows - 1) / 2])
    forward = (
        rigid_matrix(size / 2 + shift[0], size / 2 + shift[1], 0.0)
        @ rigid_matrix(0.0, 0.0, theta)
        @ rigid_matrix(*(-centre_in), 0.0)
    )
    return warp_cells(grid, forward, (size, size)), np.linalg.inv(forward)
