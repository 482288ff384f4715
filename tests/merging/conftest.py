"""Fixtures for the merger's tests: a synthetic building."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.typing import NDArray

from tests.merging.builders import synthetic_building


@pytest.fixture(scope="session")
def building() -> NDArray[np.int8]:
    """A synthetic building (seed 3)."""
    return synthetic_building(3)
