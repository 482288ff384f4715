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

This module holds the fields and the schedule; the loops over cells and
steps run compiled (:mod:`merging.evidence.refine_kernels`), with the same numbers
as numpy statements would give.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from merging.evidence.blur import gaussian_kernel
from merging.evidence.refine_kernels import field_sums, gauss_newton, sample_field, wall_field
from merging.evidence.verify import PreparedMap
from merging.params import FROM_START, GaussNewtonParams
from merging.transforms import apply_transform

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

    __slots__ = (
        "_boxed",
        "_curvature",
        "_downsample_from",
        "_fields",
        "_shape",
        "_walls",
        "_whole_share",
    )

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
        # The latest fields of boxes, oldest first (at most BOXED_FIELDS_KEPT).
        self._boxed: dict[tuple[float, tuple[int, int, int, int]], Field] = {}
        # The last curvature_matrix call: (map 2, matrix, local, params) and its answer.
        self._curvature: tuple[Any, ...] | None = None

    @property
    def shape(self) -> tuple[int, int]:
        """``(rows, cols)`` of map 1."""
        return self._shape

    def field(self, sigma: float, *, box: tuple[int, int, int, int] | None = None) -> Field:
        """The field at width ``sigma`` (cells), over all of map 1 or over ``box``.

        ``box = (x_lo, y_lo, x_hi, y_hi)`` in cells (exclusive upper bounds)
        computes the field of that part only: cheaper when only the overlap
        matters. The latest :data:`BOXED_FIELDS_KEPT` of those are kept, as a
        placement that moved less than a cell asks for the same box again
        (a refined candidate's curvature, say). A box covering more than
        ``whole_field_share`` of the map takes the whole map's field
        instead, computed once for every candidate and the curvature.
        """
        if box is not None:
            x_lo, y_lo, x_hi, y_hi = box
            if (x_hi - x_lo) * (y_hi - y_lo) > self._whole_share * self._shape[0] * self._shape[1]:
                box = None
        if box is None and sigma in self._fields:
            return self._fields[sigma]
        if box is not None:
            key = (sigma, (int(box[0]), int(box[1]), int(box[2]), int(box[3])))
            if key in self._boxed:
                return self._boxed[key]
        scale = field_scale(sigma, self._downsample_from)
        x_lo, y_lo, x_hi, y_hi = box if box is not None else (0, 0, self._shape[1], self._shape[0])
        rows, cols = (int(np.ceil(n / scale)) for n in (y_hi - y_lo, x_hi - x_lo))
        width = sigma / scale
        # Scaled so that the centre of a one-cell wall is about 1.
        gain = float(np.float32(np.sqrt(2 * np.pi) * width))
        corners = (int(x_lo), int(y_lo), int(x_hi), int(y_hi))
        kernel = gaussian_kernel(width, 3.0)
        shape = (max(rows, 1), max(cols, 1))
        space = _work_space(shape[0] * shape[1])
        image = wall_field(self._walls, corners, box is not None, scale, shape, kernel, gain,
                           space)  # fmt: skip
        field = Field(image, scale, (x_lo, y_lo), sigma)
        if box is None:
            self._fields[sigma] = field
        else:
            if len(self._boxed) >= BOXED_FIELDS_KEPT:
                del self._boxed[next(iter(self._boxed))]
            self._boxed[key] = field
        return field


BOXED_FIELDS_KEPT = 8
"""Fields of boxes a smoothed map keeps: on the low-overlap windows a fifth of the boxed
fields asked for had been asked for before, most of them a few calls earlier."""

WORK_SPACE_CELLS = 1 << 20
"""Field pixels up to which a thread keeps the blur's work space (17 MB) for the next field."""

_kept = threading.local()


def _work_space(
    cells: int,
) -> tuple[NDArray[np.uint8], NDArray[np.float64], NDArray[np.float64]]:
    """Zeroed work space of :func:`merging.evidence.blur.blur_sums` for ``cells`` pixels.

    A field of a few hundred thousand pixels in fresh memory costs more in the
    operating system's page faults than in its sums; the kernels leave the
    space zeroed, so each thread keeps one for fields up to
    :data:`WORK_SPACE_CELLS` pixels.
    """
    space = getattr(_kept, "space", None)
    if space is not None and space[0].size >= cells:
        return space
    size = 1 << max(cells - 1, 1).bit_length()  # room to grow into
    if size > WORK_SPACE_CELLS:
        return (np.zeros(cells, dtype=np.uint8), np.zeros(cells), np.zeros(cells))
    space = (np.zeros(size, dtype=np.uint8), np.zeros(size), np.zeros(size))
    _kept.space = space
    return space


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


def _field_sample(
    field: Field, matrix: NDArray[np.float64], points: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """:func:`~merging.evidence.refine_kernels.sample_field` of ``field`` at ``points`` moved by
    ``matrix``."""
    return sample_field(
        field.image,
        np.ascontiguousarray(matrix, dtype=np.float64),
        np.ascontiguousarray(points, dtype=np.float64),
        float(field.corner[0]),
        float(field.corner[1]),
        float(field.scale),
    )


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
    """Newton-length Gauss-Newton steps on one field.

    The steps are :func:`merging.evidence.refine_kernels.gauss_newton`'s.

    A step that lowers ``Σ M`` is taken back and halved (at most
    ``params.backtracks`` times in a row); the best transform seen is returned.
    """
    return gauss_newton(
        field.image,
        float(field.corner[0]),
        float(field.corner[1]),
        float(field.scale),
        float(field.sigma),
        np.ascontiguousarray(points, dtype=np.float64),
        np.ascontiguousarray(start, dtype=np.float64),
        int(iterations),
        int(params.backtracks),
        float(params.damping),
        float(params.newton_factor),
        float(params.max_step_cells),
        float(params.max_step_sigmas),
        float(params.converged_cells),
    )


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
    curvature, stride = curvature_matrix(smoothed, second, matrix, local=local, params=params)
    if curvature is None:
        return 0.0
    smallest = float(np.linalg.eigvalsh(0.5 * (curvature + curvature.T))[0])
    return max(smallest, 0.0) * stride


def turning_strength(
    smoothed: SmoothedMap,
    second: PreparedMap,
    matrix: NDArray[np.float64],
    *,
    local: bool = False,
    params: GaussNewtonParams = DEFAULT_GAUSS_NEWTON,
) -> float:
    """How firmly the walls hold the turn alone, in matching cells per cell² of motion.

    As :func:`constraint_strength`, but for turning only, the translation
    following to its best (the Schur complement of the translation block of
    the curvature), per cell² of the RMS motion of map 2's cells that the
    turn and its following translation make: near zero when map 2 may turn
    about the overlap, however firmly the overlap holds its place.
    """
    curvature, stride = curvature_matrix(smoothed, second, matrix, local=local, params=params)
    if curvature is None:
        return 0.0
    curvature = 0.5 * (curvature + curvature.T)
    shift, coupling = curvature[:2, :2], curvature[:2, 2]
    try:
        follow = np.linalg.solve(shift, coupling)
    except np.linalg.LinAlgError:
        return 0.0
    # The turn with its following translation, (-follow, 1) in whitened coordinates,
    # moves map 2's cells by its length RMS (the metric is about their centroid).
    loss = float(curvature[2, 2] - coupling @ follow)
    return max(loss, 0.0) / (1.0 + float(follow @ follow)) * stride


def curvature_matrix(
    smoothed: SmoothedMap,
    second: PreparedMap,
    matrix: NDArray[np.float64],
    *,
    local: bool = False,
    params: GaussNewtonParams = DEFAULT_GAUSS_NEWTON,
) -> tuple[NDArray[np.float64] | None, int]:
    """The curvature of :func:`constraint_strength` (whitened, coordinates ``(x, y, turn)``,
    per point used) and the stride of map 2's points it used; None where map 2 lands off
    a local field.

    The answer of the last call on ``smoothed`` is kept (read-only): the verdict asks
    for the curvature at one placement twice, for the constraint and the turn.
    """
    matrix = np.ascontiguousarray(matrix, dtype=np.float64)
    key = matrix.tobytes()  # to the bit
    kept = smoothed._curvature
    if kept is not None and kept[0] is second and kept[1:4] == (key, local, params):
        return kept[4], kept[5]
    curvature, stride = _curvature_matrix(smoothed, second, matrix, local=local, params=params)
    if curvature is not None:
        curvature.setflags(write=False)
    smoothed._curvature = (second, key, local, params, curvature, stride)
    return curvature, stride


def _curvature_matrix(
    smoothed: SmoothedMap,
    second: PreparedMap,
    matrix: NDArray[np.float64],
    *,
    local: bool,
    params: GaussNewtonParams,
) -> tuple[NDArray[np.float64] | None, int]:
    """:func:`curvature_matrix`, computed."""
    stride = max(1, int(np.ceil(len(second.points) / params.curvature_points)))
    points = second.points[::stride]
    sigma = params.curvature_sigma
    box = _landing_box(matrix, points, smoothed, sigma, params.local_margin) if local else None
    if local and box is None:
        return None, stride
    field = smoothed.field(sigma, box=box)
    landed = apply_transform(matrix, points)
    pivot = landed.mean(axis=0)
    rel = landed - pivot
    # Motion metric: translation moves every cell by 1, rotation by its radius.
    metric = np.diag([1.0, 1.0, float(np.mean(np.sum(rel**2, axis=1)))])
    # Steps of one cell of RMS motion along each coordinate.
    steps = params.curvature_step / np.sqrt(np.diag(metric))

    # Σ M at the transform and moved along each pair of coordinates, in one call.
    basis = np.eye(3) * steps
    moves = [np.zeros(3)]
    for i in range(3):
        moves += [basis[i], -basis[i]]
        for j in range(i + 1, 3):
            moves += [basis[i] + basis[j], basis[i] - basis[j]]
            moves += [-basis[i] + basis[j], -basis[i] - basis[j]]
    sums = iter(
        field_sums(
            field.image,
            float(field.corner[0]),
            float(field.corner[1]),
            float(field.scale),
            np.ascontiguousarray(points, dtype=np.float64),
            np.ascontiguousarray(matrix, dtype=np.float64),
            np.ascontiguousarray(pivot, dtype=np.float64),
            np.array(moves),
        ).tolist()
    )
    centre = next(sums)
    hessian = np.zeros((3, 3))
    for i in range(3):
        plus, minus = next(sums), next(sums)
        hessian[i, i] = (plus - 2 * centre + minus) / steps[i] ** 2
        for j in range(i + 1, 3):
            pp, pm, mp, mm = next(sums), next(sums), next(sums), next(sums)
            hessian[i, j] = hessian[j, i] = (pp - pm - mp + mm) / (4 * steps[i] * steps[j])
    whiten = np.diag(1.0 / np.sqrt(np.diag(metric)))
    return -whiten @ hessian @ whiten, stride
