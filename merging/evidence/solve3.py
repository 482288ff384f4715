"""Three-by-three linear solves for the compiled kernels, in plain arithmetic.

The refinement solves its 3 x 3 normal equations at every Gauss-Newton step
(:func:`merging.evidence.refine_kernels.gauss_newton`) and the verification
inverts the placement it checks (:func:`merging.evidence.verify.verify`).
``np.linalg.solve`` inside a numba kernel calls LAPACK through a wrapper
whose compilation (with its error reporting) took 5.5 of the 13.3 seconds a
fresh install spent before its first merge. Gaussian elimination
with partial pivoting on three unknowns is a dozen lines, compiles in a
fraction of a second and gives the same answer to the last bit or two; it
also gives the same bits on every machine, where LAPACK's kernels are chosen
for the processor they run on.
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray


@numba.njit(cache=True, nogil=True)
def solve3(matrix: NDArray[np.float64], rhs: NDArray[np.float64]) -> NDArray[np.float64]:
    """``x`` with ``matrix @ x == rhs``, for a (3, 3) ``matrix`` and a (3,) ``rhs``.

    Gaussian elimination with partial pivoting (the row with the largest
    magnitude in each column, the first of equals, as LAPACK's ``getrf``
    picks), then back substitution.

    Raises
    ------
    ZeroDivisionError
        When a pivot is zero: the matrix is singular.
    """
    a = np.empty((3, 3))
    x = np.empty(3)
    for i in range(3):
        x[i] = rhs[i]
        for j in range(3):
            a[i, j] = matrix[i, j]
    for k in range(3):
        pivot = k
        for i in range(k + 1, 3):
            if abs(a[i, k]) > abs(a[pivot, k]):
                pivot = i
        if a[pivot, k] == 0.0:
            raise ZeroDivisionError("the 3 x 3 system is singular")
        if pivot != k:
            for j in range(3):
                a[k, j], a[pivot, j] = a[pivot, j], a[k, j]
            x[k], x[pivot] = x[pivot], x[k]
        for i in range(k + 1, 3):
            factor = a[i, k] / a[k, k]
            for j in range(k + 1, 3):
                a[i, j] -= factor * a[k, j]
            x[i] -= factor * x[k]
    for i in range(2, -1, -1):
        total = x[i]
        for j in range(i + 1, 3):
            total -= a[i, j] * x[j]
        x[i] = total / a[i, i]
    return x


@numba.njit(cache=True, nogil=True)
def inverse3(matrix: NDArray[np.float64]) -> NDArray[np.float64]:
    """The inverse of a (3, 3) ``matrix``: :func:`solve3` against each column of the
    identity. Raises ZeroDivisionError for a singular one."""
    inverse = np.empty((3, 3))
    for column in range(3):
        unit = np.zeros(3)
        unit[column] = 1.0
        solved = solve3(matrix, unit)
        for row in range(3):
            inverse[row, column] = solved[row]
    return inverse
