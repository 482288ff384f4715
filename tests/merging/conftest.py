"""Fixtures for the merger's tests: a synthetic building and the real maps."""

from __future__ import annotations

import importlib.util
import os
import sys
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest
from numpy.typing import NDArray

REPO_ROOT = Path(__file__).resolve().parents[2]
MAPS_ENV = "TOMOSIM_MAPS"
"""Environment variable naming the folder of real maps; default ``<repo root>/../shared/maps``."""


def load_script(name: str) -> ModuleType:
    """The module of ``scripts/<name>.py`` (the scripts are not a package)."""
    path = REPO_ROOT / "scripts" / f"{name}.py"
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses resolve their module by name
    spec.loader.exec_module(module)
    return module


def real_maps_dir() -> Path | None:
    """The folder of real maps, or None when it is absent."""
    configured = os.environ.get(MAPS_ENV)
    folder = Path(configured) if configured else REPO_ROOT.parent / "shared" / "maps"
    return folder if folder.is_dir() else None


@pytest.fixture(scope="session")
def maps_folder() -> Path:
    """The real maps; skips the test with a reason when they are absent."""
    folder = real_maps_dir()
    if folder is None:
        pytest.skip(f"real maps not found; set {MAPS_ENV} or place them at ../shared/maps")
    return folder


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


@pytest.fixture(scope="session")
def building() -> NDArray[np.int8]:
    """A synthetic building (seed 3)."""
    return synthetic_building(3)


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
