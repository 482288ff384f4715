"""Fixtures for every test folder: the real maps, skipped with a reason when absent."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.support import MAPS_ENV, real_maps_dir


@pytest.fixture(scope="session")
def maps_folder() -> Path:
    """The real maps; skips the test with a reason when they are absent."""
    folder = real_maps_dir()
    if folder is None:
        pytest.skip(f"real maps not found; set {MAPS_ENV} or place them at ../shared/maps")
    return folder
