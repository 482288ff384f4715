"""Sub-cell, sub-degree refinement of a transform by Gauss-Newton on a smoothed map.

Map 1's occupied cells are blurred into a smooth field ``M`` that is about 1
on a wall and falls off over ``sigma`` cells. For map 2's occupied cells
``p`` and a pose ``ξ = (dx, dy, θ)``, the refinement minimises
``Σ (1 - M(T_ξ p))²``, linearising ``M`` with its bilinearly interpolated
gradient, as scan-to-map matching does (Kohlbrecher et al., "A flexible and
scalable SLAM system with full 3D motion estimation", SSRR 2011). Cells
landing far from any wall have zero gradient and no pull.

Near a wall the residual ``1 - M`` vanishes quadratically, so a plain
Gauss-Newton step covers half the distance to the wall centre (for a Gaussian
profile, exactly half); the step is therefore doubled, which is Newton's step
there, and halved again while it fails to raise ``Σ M``. A coarse-to-fine
schedule of ``sigma`` widens the basin first and sharpens the optimum last.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import NDArray

from merging.blur import blur_walls
from merging.params import FROM_START, GaussNewtonParams
from merging.transforms import apply_transform, rotation_about
from merging.verify import PreparedMap

DEFAULT_GAUSS_NEWTON = GaussNewtonParams()
"""The default step control, field and curvature settings."""


@dataclass(frozen=True, slots=True)
class Field:
    """Map 1's walls blurred at one width, over all of map 1 or a box of it.

    Cell ``(x, y)`` of map 1 lies at ``((x - corner_x + 0.5) / scale + 0.5,
    (y - corner_y + 0.5) / scale + 0.5)`` in ``image``, which has a border of
    one zero cell.
    """

    image: NDArray[np.float32]
    scale: float
    corner: tuple[int, int] = (0, 0)
    sigma: float = 1.0

    def locate(self, cells: NDArray[np.float64]) -> NDArray[np.float64]:
        """Image coordinates of ``(N, 2)`` cell coordinates of map 1."""
        return (cells - np.asarray(self.corner)) / self.scale + (0.5 / self.scale + 0.5)


class SmoothedMap:
    """Map 1's walls blurred at several widths, each computed on first use.

    Parameters
    ----------
    walls : (N, 2) float ndarray
        ``(x, y)`` of map 1's occupied cells.
    shape : (rows, cols)
        Map 1's shape.
    downsample_from_sigma : float
        Fields at least this wide (cells) are computed at a coarser resolution.
    whole_field_share : float
        Share of the map above which a local field is the whole map's.
    """

    __slots__ = ("_downsample_from", "_fields", "_shape", "_walls", "_whole_share")

    def __init__(
        self,
        walls: NDArray[np.float64],
        shape: tuple[int, int],
        *,
        downsample_from_sigma: float = DEFAULT_GAUSS_NEWTON.downsample_from_sigma,
        whole_field_share: float = DEFAULT_GAUSS_NEWTON.whole_field_share,
    ) -> None:
        self._walls = walls
        self._shape = shape
        self._downsample_from = downsample_from_sigma
        self._whole_share = whole_field_share
        self._fields: dict[float, Field] = {}

    @property
    def shape(self) -> tuple[int, int]:
        """``(rows, cols)`` of map 1."""
        return self._shape

    def field(self, sigma: float, *, box: tuple[int, int, int, int] | None = None) -> Field:
        """The field at width ``sigma`` (cells), over all of map 1 or over ``box``.

        ``box = (x_lo, y_lo, x_hi, y_hi)`` in cells (exclusive upper bounds)
        computes the field of that part only, uncached: cheaper when only
        the overlap matters. A box covering more than ``whole_field_share``
        of the map takes the whole map's field instead, computed once for
        every candidate and the curvature.
        """
        if box is not None:
            x_lo, y_lo, x_hi, y_hi = box
            if (x_hi - x_lo) * (y_hi - y_lo) > self._whole_share * self._shape[0] * self._shape[1]:
                box = None
        if box is None and sigma in self._fields:
            return self._fields[sigma]
        scale = field_scale(sigma, self._downsample_from)
        x_lo, y_lo, x_hi, y_hi = box if box is not None else (0, 0, self._shape[1], self._shape[0])
        rows, cols = (int(np.ceil(n / scale)) for n in (y_hi - y_lo, x_hi - x_lo))
        walls = self._walls
        if box is not None:
            inside = (
                (walls[:, 0] >= x_lo)
                & (walls[:, 0] < x_hi)
                & (walls[:, 1] >= y_lo)
                & (walls[:, 1] < y_hi)
            )
            walls = walls[inside]
        cells = ((walls - np.array([x_lo, y_lo])) // scale).astype(np.intp)
        width = sigma / scale
        # Scaled so that the centre of a one-cell wall is about 1.
        smooth = blur_walls(cells[:, 1], cells[:, 0], (max(rows, 1), max(cols, 1)), width,
                            truncate=3.0)  # fmt: skip
        smooth *= np.float32(np.sqrt(2 * np.pi) * width)
        field = Field(np.pad(np.minimum(smooth, 1.0), 1), scale, (x_lo, y_lo), sigma)
        if box is None:
            self._fields[sigma] = field
        return field


def field_scale(sigma: float, downsample_from: float) -> float:
    """Cells per field pixel for a field of width ``sigma``: 1 below ``downsample_from``.

    From ``downsample_from`` on, the largest power of two not above ``sigma``
    (at least 2): a blur of ``sigma`` cells has nothing finer to keep, and the
    field of a coarse-to-fine search's widest stage then costs as much on a
    4000-cell map as on a 400-cell one.
    """
    if sigma < downsample_from:
        return 1.0
    return float(max(2.0, 2.0 ** np.floor(np.log2(sigma))))


@numba.njit(cache=True, nogil=True)
def _sample(
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
    :func:`merging.transforms.apply_transform`, :meth:`Field.locate` and a
    bilinear lookup, which the refinement repeats hundreds of times a search.
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


def _field_sample(
    field: Field, matrix: NDArray[np.float64], points: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """:func:`_sample` of ``field`` at ``points`` moved by ``matrix``."""
    return _sample(
        field.image,
        np.ascontiguousarray(matrix, dtype=np.float64),
        np.ascontiguousarray(points, dtype=np.float64),
        float(field.corner[0]),
        float(field.corner[1]),
        float(field.scale),
    )


def _objective(field: Field, matrix: NDArray[np.float64], points: NDArray[np.float64]) -> float:
    """``Σ M`` over ``points`` moved by ``matrix`` (those landing off the field add 0)."""
    _, value, _, _ = _field_sample(field, matrix, points)
    return float(value.sum())


def refine_transform(
    smoothed: SmoothedMap,
    second: PreparedMap,
    matrix: NDArray[np.float64],
    *,
    sigmas: tuple[float, ...] = FROM_START.sigmas,
    iterations: int = FROM_START.iterations,
    local: bool = False,
    max_points: int = FROM_START.points,
    params: GaussNewtonParams = DEFAULT_GAUSS_NEWTON,
) -> NDArray[np.float64]:
    """Refine ``matrix`` (map 2 cells -> map 1 cells) to sub-cell accuracy.

    Parameters
    ----------
    smoothed : SmoothedMap
        Map 1's fields.
    second : PreparedMap
        Map 2; up to ``max_points`` of its occupied cells are moved.
    matrix : (3, 3) float ndarray
        Starting transform.
    sigmas : tuple of float
        Field widths to run, widest first.
    iterations : int
        Gauss-Newton steps per width at most.
    local : bool
        Blur only the part of map 1 where map 2's cells land (plus
        ``params.local_margin``): for a start already within a cell or so.
    max_points : int
        Map 2 cells moved at most.
    params : GaussNewtonParams
        Step control and the local field's margin.

    Returns
    -------
    (3, 3) float ndarray
        The refined transform; the input when too few cells land on map 1.
    """
    current = np.asarray(matrix, dtype=float).copy()
    stride = max(1, int(np.ceil(len(second.points) / max_points)))
    points = second.points[::stride]
    for sigma in sigmas:
        box = _landing_box(current, points, smoothed, sigma, params.local_margin) if local else None
        if local and box is None:
            return current
        field = smoothed.field(sigma, box=box)
        current = _gauss_newton(field, points, current, iterations, params)
    return current


def _landing_box(
    matrix: NDArray[np.float64],
    points: NDArray[np.float64],
    smoothed: SmoothedMap,
    sigma: float,
    margin_cells: float,
) -> tuple[int, int, int, int] | None:
    """Cells of map 1 where ``points`` land, grown by the blur and ``margin_cells``."""
    rows, cols = smoothed.shape
    landed = apply_transform(matrix, points)
    margin = margin_cells + 3.0 * sigma
    x_lo = max(int(np.floor(landed[:, 0].min() - margin)), 0)
    y_lo = max(int(np.floor(landed[:, 1].min() - margin)), 0)
    x_hi = min(int(np.ceil(landed[:, 0].max() + margin)) + 1, cols)
    y_hi = min(int(np.ceil(landed[:, 1].max() + margin)) + 1, rows)
    if x_hi <= x_lo or y_hi <= y_lo:
        return None
    return x_lo, y_lo, x_hi, y_hi


def _gauss_newton(
    field: Field,
    points: NDArray[np.float64],
    start: NDArray[np.float64],
    iterations: int,
    params: GaussNewtonParams,
) -> NDArray[np.float64]:
    """Newton-length Gauss-Newton steps on one field; each evaluation also checks the last step.

    A step that lowers ``Σ M`` is taken back and halved (at most
    ``params.backtracks`` times in a row); the best transform seen is returned.
    """
    scale = field.scale
    best, best_total = start, -np.inf
    current = start
    step = np.zeros(3)
    pivot = np.zeros(2)
    halvings = 0
    for _ in range(iterations + params.backtracks):
        landed, value, gx, gy = _field_sample(field, current, points)
        if len(value) < 3:
            break
        total = float(value.sum())
        if total <= best_total:
            if halvings == params.backtracks:
                break
            step /= 2
            halvings += 1
            current = _step_matrix(step, pivot) @ best
            continue
        best, best_total, halvings = current, total, 0
        pivot, radius, normal, rhs = _normal_equations(landed, value, gx, gy, scale)
        normal += params.damping * (np.trace(normal) / 3 + 1e-12) * np.eye(3)
        motion = params.newton_factor * np.linalg.solve(normal, rhs)
        length = float(np.linalg.norm(motion))
        longest = max(params.max_step_cells, params.max_step_sigmas * field.sigma)
        if length > longest:
            motion *= longest / length
        if length < params.converged_cells:
            break
        step = np.array([motion[0], motion[1], motion[2] / radius])
        current = _step_matrix(step, pivot) @ best
    return best


@numba.njit(cache=True, nogil=True)
def _normal_equations(
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


def _step_matrix(step: NDArray[np.float64], pivot: NDArray[np.float64]) -> NDArray[np.float64]:
    """Turn by ``step[2]`` about ``pivot``, then shift by ``step[:2]``."""
    update = rotation_about(float(step[2]), pivot)
    update[:2, 2] += step[:2]
    return update


def constraint_strength(
    smoothed: SmoothedMap,
    second: PreparedMap,
    matrix: NDArray[np.float64],
    *,
    local: bool = False,
    params: GaussNewtonParams = DEFAULT_GAUSS_NEWTON,
) -> float:
    """How firmly the walls pin the transform down, in matching cells.

    The Hessian ``H`` of ``Σ M(T_ξ p)`` at ``matrix`` (central differences on
    the field of width ``params.curvature_sigma``) is compared with ``G``,
    the mean squared motion of map 2's cells per unit of ``ξ``. The smallest
    generalised eigenvalue of ``(-H, G)`` is the loss of matching cells per
    cell² of RMS motion along the least constrained direction: close to the number of wall cells
    holding that direction (a cell on a wall loses about one per cell²), and
    near zero when the overlap is one straight wall that lets map 2 slide or
    turn. ``local`` blurs only where map 2 lands (see :func:`refine_transform`).
    """
    stride = max(1, int(np.ceil(len(second.points) / params.curvature_points)))
    points = second.points[::stride]
    sigma = params.curvature_sigma
    box = _landing_box(matrix, points, smoothed, sigma, params.local_margin) if local else None
    if local and box is None:
        return 0.0
    field = smoothed.field(sigma, box=box)
    landed = apply_transform(matrix, points)
    pivot = landed.mean(axis=0)
    rel = landed - pivot
    # Motion metric: translation moves every cell by 1, rotation by its radius.
    metric = np.diag([1.0, 1.0, float(np.mean(np.sum(rel**2, axis=1)))])
    # Steps of one cell of RMS motion along each coordinate.
    steps = params.curvature_step / np.sqrt(np.diag(metric))

    def objective(delta: NDArray[np.float64]) -> float:
        update = rotation_about(delta[2], pivot)
        update[:2, 2] += delta[:2]
        return _objective(field, update @ matrix, points)

    centre = objective(np.zeros(3))
    hessian = np.zeros((3, 3))
    basis = np.eye(3) * steps
    for i in range(3):
        plus, minus = objective(basis[i]), objective(-basis[i])
        hessian[i, i] = (plus - 2 * centre + minus) / steps[i] ** 2
        for j in range(i + 1, 3):
            pp = objective(basis[i] + basis[j])
            pm = objective(basis[i] - basis[j])
            mp = objective(-basis[i] + basis[j])
            mm = objective(-basis[i] - basis[j])
            hessian[i, j] = hessian[j, i] = (pp - pm - mp + mm) / (4 * steps[i] * steps[j])
    whiten = np.diag(1.0 / np.sqrt(np.diag(metric)))
    curvature = -whiten @ hessian @ whiten
    smallest = float(np.linalg.eigvalsh(0.5 * (curvature + curvature.T))[0])
    return max(smallest, 0.0) * stride
