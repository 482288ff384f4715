"""Fixtures for every test folder: the real maps, skipped with a reason when absent."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.support import maps_absent_reason, real_maps_dir


@pytest.fixture(scope="session")
def maps_folder() -> Path:
    """The real maps; skips the test with a reason when they are absent."""
    folder = real_maps_dir()
    if folder is None:
        pytest.skip(maps_absent_reason())
    return folder
