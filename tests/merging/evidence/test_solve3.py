"""The kernels' 3 x 3 solve against numpy's, and compiled against its own Python."""

from __future__ import annotations

import numpy as np
import pytest

from merging.evidence.solve3 import inverse3, solve3
from merging.transforms import rigid_matrix


def _systems(count: int, seed: int):
    generator = np.random.default_rng(seed)
    for _ in range(count):
        matrix = generator.normal(size=(3, 3))
        if generator.random() < 0.5:  # a damped normal matrix, as the refinement solves
            matrix = matrix @ matrix.T + 1e-3 * np.eye(3)
        yield matrix, generator.normal(size=3) * 10.0 ** generator.integers(-3, 4)


def test_solves_as_numpy_does_to_the_last_bits() -> None:
    for matrix, rhs in _systems(2000, 0):
        expected = np.linalg.solve(matrix, rhs)
        scale = np.linalg.cond(matrix) * np.max(np.abs(expected))
        assert np.max(np.abs(solve3(matrix, rhs) - expected)) <= 1e-13 * scale


def test_compiled_solve_is_its_python_to_the_bit() -> None:
    for matrix, rhs in _systems(500, 1):
        assert np.array_equal(solve3(matrix, rhs), solve3.py_func(matrix, rhs))


def test_pivots_on_the_largest_entry() -> None:
    # Without row exchanges the first pivot, 1e-20, would swamp the second row.
    matrix = np.array([[1e-20, 1.0, 0.0], [1.0, 1.0, 0.0], [0.0, 0.0, 2.0]])
    assert np.allclose(solve3(matrix, np.array([1.0, 2.0, 4.0])), [1.0, 1.0, 2.0])


@pytest.mark.parametrize("pose", [(12.0, -7.0, 0.35), (-300.5, 41.25, -2.9), (0.0, 0.0, np.pi)])
def test_inverts_a_placement(pose) -> None:
    matrix = rigid_matrix(*pose)
    assert np.allclose(inverse3(matrix), np.linalg.inv(matrix), rtol=0, atol=1e-12)
    assert np.allclose(inverse3(matrix) @ matrix, np.eye(3), rtol=0, atol=1e-12)


def test_refuses_a_singular_system() -> None:
    singular = np.array([[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 1.0, 1.0]])
    with pytest.raises(ZeroDivisionError, match="singular"):
        solve3(singular, np.ones(3))
