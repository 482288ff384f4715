"""The refinement's compiled inner loops (:mod:`merging.evidence.refine`).

A search refines a dozen candidates over several field widths, each in up to
a dozen Gauss-Newton steps, and the curvature of the fit takes thirteen more
evaluations of ``Σ M``: on the small maps of a low-overlap pair, calling numpy
for each small step cost more than the arithmetic. These kernels run a whole
stage, or all evaluations, in one call.

They compute what the numpy statements of the earlier Python loops computed,
bit for bit: a sum of the field's values is numpy's pairwise sum
(:func:`pairwise_sum`), and products of 3 x 3 matrices and the step's length
go through the same BLAS routines numpy calls. The 3 x 3 normal equations are
solved by :func:`merging.evidence.solve3.solve3`, which agrees with numpy's
LAPACK solve to the last bits and compiles in a fraction of the time
(``tests/merging/evidence/test_refine_kernels.py`` holds the compiled loop to
the numpy statements with that solve).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

from merging.evidence.blur import blur_sums
from merging.evidence.solve3 import solve3

PAIRWISE_BLOCK = 128
"""Values numpy's pairwise summation adds in eight running sums before it halves a run."""


@numba.njit(cache=True, nogil=True)
def _pairwise_block(values: NDArray[np.float64], start: int, count: int) -> float:
    """numpy's sum of a run of at most :data:`PAIRWISE_BLOCK` values: eight running sums."""
    if count < 8:
        total = 0.0
        for i in range(start, start + count):
            total += values[i]
        return total
    r0, r1, r2, r3 = values[start], values[start + 1], values[start + 2], values[start + 3]
    r4, r5, r6, r7 = values[start + 4], values[start + 5], values[start + 6], values[start + 7]
    i = 8
    whole = count - count % 8
    while i < whole:
        at = start + i
        r0 += values[at]
        r1 += values[at + 1]
        r2 += values[at + 2]
        r3 += values[at + 3]
        r4 += values[at + 4]
        r5 += values[at + 5]
        r6 += values[at + 6]
        r7 += values[at + 7]
        i += 8
    total = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < count:
        total += values[start + i]
        i += 1
    return total


@numba.njit(cache=True, nogil=True)
def pairwise_sum(values: NDArray[np.float64]) -> float:
    """``values.sum()`` as numpy adds a contiguous 1-D float64 array, to the last bit.

    numpy's ``pairwise_sum_DOUBLE``: a run longer than :data:`PAIRWISE_BLOCK`
    is split in two (the first half a multiple of 8) and the halves' sums
    added. Written with an explicit stack: a cached recursive kernel crashes
    numba when it is loaded from the cache.
    """
    count = values.shape[0]
    if count <= PAIRWISE_BLOCK:
        return 0.0 + _pairwise_block(values, 0, count)
    # Frames of the recursion: a run, whether its first half is summed, and that sum.
    starts = np.empty(64, dtype=np.int64)
    counts = np.empty(64, dtype=np.int64)
    firsts = np.empty(64)
    halves_done = np.zeros(64, dtype=np.bool_)
    depth = 0
    starts[0], counts[0], halves_done[0] = 0, count, False
    result = 0.0
    returning = False
    while True:
        if returning:
            # ``result`` is the sum of the run this frame asked for last.
            if not halves_done[depth]:
                firsts[depth] = result
                halves_done[depth] = True
                half = counts[depth] // 2
                half -= half % 8
                starts[depth + 1] = starts[depth] + half
                counts[depth + 1] = counts[depth] - half
                halves_done[depth + 1] = False
                depth += 1
                returning = False
                continue
            result = firsts[depth] + result
            if depth == 0:
                return 0.0 + result
            depth -= 1
            continue
        run = counts[depth]
        if run <= PAIRWISE_BLOCK:
            result = _pairwise_block(values, starts[depth], run)
            depth -= 1
            returning = True
            continue
        half = run // 2
        half -= half % 8
        starts[depth + 1] = starts[depth]
        counts[depth + 1] = half
        halves_done[depth + 1] = False
        depth += 1


@numba.njit(cache=True, nogil=True)
def sample_field(
    image: NDArray[np.float32],
    matrix: NDArray[np.float64],
    points: NDArray[np.float64],
    corner_x: float,
    corner_y: float,
    scale: float,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Move ``points`` (map 2 cells) by ``matrix`` and sample the field ``image`` there.

    Returns, for the points that land inside the image (its last row and
    column excluded, so that every bilinear neighbour exists): where they
    land in map 1's cells ``(K, 2)``, and the field's bilinear value and
    gradient along x and y in image pixels at each. The compiled form of
    :func:`merging.transforms.apply_transform`, :meth:`merging.evidence.refine.Field.locate`
    and a bilinear lookup, which the refinement repeats hundreds of times a search.
    """
    count = points.shape[0]
    rows, cols = image.shape
    landed = np.empty((count, 2))
    value = np.empty(count)
    grad_x = np.empty(count)
    grad_y = np.empty(count)
    a, b, c = matrix[0, 0], matrix[0, 1], matrix[0, 2]
    d, e, f = matrix[1, 0], matrix[1, 1], matrix[1, 2]
    offset = 0.5 / scale + 0.5
    kept = 0
    for i in range(count):
        px, py = points[i, 0], points[i, 1]
        cell_x = px * a + py * b + c
        cell_y = px * d + py * e + f
        x = (cell_x - corner_x) / scale + offset
        y = (cell_y - corner_y) / scale + offset
        if not (x >= 0.0 and x < cols - 1 and y >= 0.0 and y < rows - 1):
            continue
        x0 = int(np.floor(x))
        y0 = int(np.floor(y))
        fx, fy = x - x0, y - y0
        v00 = np.float64(image[y0, x0])
        v01 = np.float64(image[y0, x0 + 1])
        v10 = np.float64(image[y0 + 1, x0])
        v11 = np.float64(image[y0 + 1, x0 + 1])
        top = v00 * (1.0 - fx) + v01 * fx
        bottom = v10 * (1.0 - fx) + v11 * fx
        landed[kept, 0] = cell_x
        landed[kept, 1] = cell_y
        value[kept] = top * (1.0 - fy) + bottom * fy
        grad_x[kept] = (v01 - v00) * (1.0 - fy) + (v11 - v10) * fy
        grad_y[kept] = bottom - top
        kept += 1
    return landed[:kept], value[:kept], grad_x[:kept], grad_y[:kept]


@numba.njit(cache=True, nogil=True)
def normal_equations(
    landed: NDArray[np.float64],
    value: NDArray[np.float64],
    grad_x: NDArray[np.float64],
    grad_y: NDArray[np.float64],
    scale: float,
) -> tuple[NDArray[np.float64], float, NDArray[np.float64], NDArray[np.float64]]:
    """Gauss-Newton's normal equations ``JᵀJ ξ = Jᵀ(1 - M)`` for a motion about the pivot.

    ``landed`` are the moved cells, ``value`` and ``grad_*`` the field and its
    gradient there (image pixels, ``scale`` cells each). The unknowns are the
    shift along x and y and the turn about the cells' mean (the pivot),
    measured in cells of RMS motion (turn times the RMS radius), like the
    shift, so that damping and step limits treat all three alike on a map of
    any size. Returns the pivot, the RMS radius, ``JᵀJ`` and ``Jᵀ(1 - M)``.
    """
    count = landed.shape[0]
    pivot = np.zeros(2)
    for i in range(count):
        pivot[0] += landed[i, 0]
        pivot[1] += landed[i, 1]
    pivot /= count
    spread = 0.0
    for i in range(count):
        spread += (landed[i, 0] - pivot[0]) ** 2 + (landed[i, 1] - pivot[1]) ** 2
    radius = np.sqrt(spread / count) + 1e-9
    normal = np.zeros((3, 3))
    rhs = np.zeros(3)
    row = np.empty(3)
    for i in range(count):
        gx, gy = grad_x[i] / scale, grad_y[i] / scale
        row[0] = gx
        row[1] = gy
        row[2] = (-gx * (landed[i, 1] - pivot[1]) + gy * (landed[i, 0] - pivot[0])) / radius
        residual = 1.0 - value[i]
        for j in range(3):
            rhs[j] += row[j] * residual
            for k in range(3):
                normal[j, k] += row[j] * row[k]
    return pivot, radius, normal, rhs


@numba.njit(cache=True, nogil=True)
def step_matrix(
    shift_x: float, shift_y: float, turn: float, pivot_x: float, pivot_y: float
) -> NDArray[np.float64]:
    """Turn by ``turn`` about ``(pivot_x, pivot_y)``, then shift: as
    :func:`merging.transforms.rotation_about` builds it, plus the shift."""
    c, s = math.cos(turn), math.sin(turn)
    update = np.empty((3, 3))
    update[0, 0], update[0, 1] = c, -s
    update[0, 2] = pivot_x - c * pivot_x + s * pivot_y + shift_x
    update[1, 0], update[1, 1] = s, c
    update[1, 2] = pivot_y - s * pivot_x - c * pivot_y + shift_y
    update[2, 0], update[2, 1], update[2, 2] = 0.0, 0.0, 1.0
    return update


@numba.njit(cache=True, nogil=True)
def gauss_newton(
    image: NDArray[np.float32],
    corner_x: float,
    corner_y: float,
    scale: float,
    sigma: float,
    points: NDArray[np.float64],
    start: NDArray[np.float64],
    iterations: int,
    backtracks: int,
    damping: float,
    newton_factor: float,
    max_step_cells: float,
    max_step_sigmas: float,
    converged_cells: float,
) -> NDArray[np.float64]:
    """Newton-length Gauss-Newton steps on one field; each evaluation also checks the last step.

    The loop of :func:`merging.evidence.refine.refine_transform` for one width
    (``image`` with its ``corner``, ``scale`` and ``sigma``; the settings of
    :class:`merging.params.GaussNewtonParams`). A step that lowers ``Σ M`` is
    taken back and halved (at most ``backtracks`` times in a row); the best
    transform seen is returned.
    """
    best = start.copy()
    best_total = -np.inf
    current = best
    step = np.zeros(3)
    pivot = np.zeros(2)
    halvings = 0
    longest = max_step_sigmas * sigma
    if not longest > max_step_cells:
        longest = max_step_cells
    for _ in range(iterations + backtracks):
        landed, value, grad_x, grad_y = sample_field(
            image, current, points, corner_x, corner_y, scale
        )
        if value.shape[0] < 3:
            break
        total = pairwise_sum(value)
        if total <= best_total:
            if halvings == backtracks:
                break
            step /= 2
            halvings += 1
            current = step_matrix(step[0], step[1], step[2], pivot[0], pivot[1]) @ best
            continue
        best, best_total, halvings = current, total, 0
        pivot, radius, normal, rhs = normal_equations(landed, value, grad_x, grad_y, scale)
        trace = 0.0 + normal[0, 0] + normal[1, 1] + normal[2, 2]
        extra = damping * (trace / 3 + 1e-12)
        for j in range(3):
            for k in range(3):
                normal[j, k] += extra * (1.0 if j == k else 0.0)
        motion = newton_factor * solve3(normal, rhs)
        length = math.sqrt(np.dot(motion, motion))
        if length > longest:
            motion *= longest / length
        if length < converged_cells:
            break
        step = np.array([motion[0], motion[1], motion[2] / radius])
        current = step_matrix(step[0], step[1], step[2], pivot[0], pivot[1]) @ best
    return best


@numba.njit(cache=True, nogil=True)
def field_sums(
    image: NDArray[np.float32],
    corner_x: float,
    corner_y: float,
    scale: float,
    points: NDArray[np.float64],
    matrix: NDArray[np.float64],
    pivot: NDArray[np.float64],
    moves: NDArray[np.float64],
) -> NDArray[np.float64]:
    """``Σ M`` over ``points`` moved by ``matrix`` and then by each row ``(dx, dy, dθ)`` of
    ``moves`` (a turn about ``pivot`` and a shift): the evaluations of a finite-difference
    Hessian (:func:`merging.evidence.refine.constraint_strength`)."""
    sums = np.empty(moves.shape[0])
    for k in range(moves.shape[0]):
        update = step_matrix(moves[k, 0], moves[k, 1], moves[k, 2], pivot[0], pivot[1])
        _, value, _, _ = sample_field(image, update @ matrix, points, corner_x, corner_y, scale)
        sums[k] = pairwise_sum(value)
    return sums


@numba.njit(cache=True, nogil=True)
def wall_field(
    walls: NDArray[np.float64],
    box: tuple[int, int, int, int],
    boxed: bool,
    scale: float,
    shape: tuple[int, int],
    kernel: NDArray[np.float64],
    gain: float,
    space: tuple[NDArray[np.uint8], NDArray[np.float64], NDArray[np.float64]],
) -> NDArray[np.float32]:
    """The image of a :class:`merging.evidence.refine.Field`: the walls ``(x, y)`` inside ``box =
    (x_lo, y_lo, x_hi, y_hi)`` (all of them unless ``boxed``), in pixels of ``scale`` cells
    from its corner, blurred (``kernel``) on ``shape`` pixels, times ``gain`` (float32),
    capped at 1 and framed by one zero pixel. ``space`` is the work space of
    :func:`merging.evidence.blur.blur_sums`, zero on entry and on return."""
    x_lo, y_lo, x_hi, y_hi = box
    count = walls.shape[0]
    rows = np.empty(count, dtype=np.intp)
    cols = np.empty(count, dtype=np.intp)
    kept = 0
    for i in range(count):
        x, y = walls[i, 0], walls[i, 1]
        if boxed and not (x >= x_lo and x < x_hi and y >= y_lo and y < y_hi):
            continue
        cols[kept] = int((x - x_lo) // scale)
        rows[kept] = int((y - y_lo) // scale)
        kept += 1
    n_rows, n_cols = shape
    state, down, sums = space
    blur_sums(rows[:kept], cols[:kept], n_rows, n_cols, kernel, state, down, sums)
    image = np.zeros((n_rows + 2, n_cols + 2), dtype=np.float32)
    factor = np.float32(gain)
    one = np.float32(1.0)
    for r in range(n_rows):
        for c in range(n_cols):
            at = r * n_cols + c
            value = np.float32(sums[at]) * factor
            sums[at] = 0.0
            image[r + 1, c + 1] = value if value < one else one
    return image
