"""The public entry point: ``estimate_transform`` and its registry of methods.

Every method is a function ``(cells1, cells2, *, rng, **options) -> MergeResult``
taking two validated ``int8`` grids; a method with a settings object (the
default's :class:`~merging.params.TomographicParams`) is registered with its
type and also takes ``params=``. :func:`estimate_transform` validates the
input, dispatches, and fills in what is common to all methods (the transform
in metres, the total time, the empty-map guard).
"""

from __future__ import annotations

import numbers
import time
from collections.abc import Callable
from dataclasses import replace
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from merging.grid import OccupancyGrid, occupied_mask, validate_cells
from merging.resample import to_resolution
from merging.result import MergeResult, checked_result
from merging.transforms import cells_to_metres
from merging.validators import RngLike, as_generator, one_of

DEFAULT_METHOD = "tomographic"
"""The method :func:`estimate_transform` uses unless told otherwise."""
MIN_OCCUPIED_CELLS = 10
"""Fewer occupied cells than this in either map cannot fix a rigid transform."""


class MergeMethod(Protocol):
    """Signature of a registered merging method."""

    def __call__(
        self,
        cells1: NDArray[np.int8],
        cells2: NDArray[np.int8],
        *,
        rng: np.random.Generator,
        **options: Any,
    ) -> MergeResult: ...


ROUNDING = 1e-9
"""How far outside [0, 1] a method's confidence may come back and be clipped, as the
rounding of a product of factors; farther is an error of the method."""

_METHODS: dict[str, MergeMethod] = {}
_PARAMS_TYPES: dict[str, type | None] = {}


def register_method(
    name: str, *, params_type: type | None = None
) -> Callable[[MergeMethod], MergeMethod]:
    """Decorator registering a merging method under ``name``.

    ``params_type`` is the type of the settings object the method takes as
    ``params=`` (None: it takes none).
    """

    if not isinstance(name, str) or not name:
        raise TypeError(f"a merging method's name must be a non-empty str, got {name!r}")

    def decorate(function: MergeMethod) -> MergeMethod:
        if name in _METHODS:
            raise ValueError(f"a merging method named {name!r} is already registered")
        _METHODS[name] = function
        _PARAMS_TYPES[name] = params_type
        return function

    return decorate


def available_methods() -> tuple[str, ...]:
    """Names accepted by ``estimate_transform(..., method=...)``."""
    return tuple(sorted(_METHODS))


def check_method(method: object) -> str:
    """Return ``method`` if it names a registered method, else raise ValueError listing them.

    The one place a method name is checked; every public entry point that
    takes one calls it before doing any work.
    """
    return one_of(method, available_methods(), what="merging method")


def estimate_transform(
    map1: OccupancyGrid | NDArray[Any],
    map2: OccupancyGrid | NDArray[Any],
    *,
    method: str = DEFAULT_METHOD,
    rng: RngLike = None,
    params: object | None = None,
    **options: Any,
) -> MergeResult:
    """Estimate the transform taking ``map2``'s cells onto ``map1``'s.

    Parameters
    ----------
    map1, map2 : OccupancyGrid or (rows, cols) array
        Grids in the ROS coding (-1 unknown, 0..100); any shapes.
    method : str
        A name from :func:`available_methods`: ``"tomographic"`` (default, the
        most accurate) or ``"paper"`` (sections 3.1-3.3 of [1] as written), and
        the baselines.
    rng : numpy.random.Generator, int or None
        Randomness for methods that sample (the paper's Monte-Carlo step).
    params : object, optional
        The method's settings object, for a method that has one: a
        :class:`merging.params.TomographicParams` for ``"tomographic"``
        (default: its documented defaults).
    **options
        Passed to the method.

    Returns
    -------
    MergeResult
        ``matrix`` (map 2 cells -> map 1 cells, eq. 1 of [1]), ``confidence``,
        ``accepted``. Valid grids that cannot be merged (empty, all unknown,
        too little structure) give ``accepted=False``; this function does not
        raise for them.

    Raises
    ------
    TypeError, ValueError
        For input that is not a grid in the ROS coding, an unknown method,
        or a ``params`` object the method does not take.

    Notes
    -----
    Two :class:`OccupancyGrid` of different resolutions are merged by
    coarsening the finer one to the coarser resolution
    (:mod:`merging.resample`) for the search; ``matrix`` still takes map 2's
    own cells to map 1's own cells, so it then scales by the ratio of the
    resolutions, and ``matrix_metres`` is rigid.

    References
    ----------
    .. [1] H. Lee, "Tomographic Feature-Based Map Merging for Multi-Robot
       Systems", Electronics 2020, 9(1), 107.
    """
    start = time.perf_counter()
    cells1 = validate_cells(map1, name="map1")
    cells2 = validate_cells(map2, name="map2")
    check_method(method)
    if params is not None:
        _check_params(method, params)
        options = {**options, "params": params}
    both_grids = isinstance(map1, OccupancyGrid) and isinstance(map2, OccupancyGrid)
    # Maps of different resolutions: the finer one is coarsened to the other's,
    # the method runs on the pair, and its matrix is carried back to the
    # original cells (where it then scales by the ratio of the resolutions).
    to_search1, to_search2 = np.eye(3), np.eye(3)
    if both_grids:
        (cells1, to_search1), (cells2, to_search2) = _common_resolution(map1, map2)  # type: ignore[arg-type]
    generator = as_generator(rng)
    counts = (
        int(np.count_nonzero(occupied_mask(cells1))),
        int(np.count_nonzero(occupied_mask(cells2))),
    )
    if min(counts) < MIN_OCCUPIED_CELLS:
        result = MergeResult(
            matrix=np.eye(3),
            confidence=0.0,
            accepted=False,
            method=method,
            reason=f"too few occupied cells to match (map1 {counts[0]}, map2 {counts[1]}; "
            f"need {MIN_OCCUPIED_CELLS})",
        )
    else:
        result = _METHODS[method](cells1, cells2, rng=generator, **options)
        # A product of factors may overshoot [0, 1] by rounding; more than that is refused.
        confidence = getattr(result, "confidence", None)
        if (
            isinstance(result, MergeResult)
            and isinstance(confidence, numbers.Real)
            and not isinstance(confidence, bool)
            and -ROUNDING <= float(confidence) <= 1.0 + ROUNDING
        ):
            result = replace(result, confidence=min(max(float(confidence), 0.0), 1.0))
        result = checked_result(result, f"the result of method {method!r}")
    timings = dict(result.timings)
    timings["total"] = time.perf_counter() - start
    from_search1 = np.linalg.inv(to_search1)
    matrix = from_search1 @ result.matrix @ to_search2
    metres = cells_to_metres(matrix, map1, map2) if both_grids else None  # type: ignore[arg-type]
    return MergeResult(
        matrix=matrix,
        confidence=float(result.confidence),
        accepted=bool(result.accepted),
        method=method,
        matrix_metres=metres,
        hypotheses=tuple(
            replace(h, matrix=from_search1 @ h.matrix @ to_search2) for h in result.hypotheses
        ),
        timings=timings,
        reason=result.reason,
        evidence=dict(result.evidence),
    )


def _common_resolution(
    map1: OccupancyGrid, map2: OccupancyGrid
) -> tuple[
    tuple[NDArray[np.int8], NDArray[np.float64]], tuple[NDArray[np.int8], NDArray[np.float64]]
]:
    """Both grids' cells at the coarser of their resolutions, each with the matrix to them."""
    coarser = max(map1.resolution, map2.resolution)
    out = []
    for grid in (map1, map2):
        resampled, matrix = to_resolution(grid, coarser)
        out.append((resampled.data, matrix))
    return out[0], out[1]


def _check_params(method: str, params: object) -> None:
    """Raise ``TypeError`` unless ``params`` is the settings type ``method`` takes."""
    wanted = _PARAMS_TYPES[method]
    if wanted is None:
        with_params = sorted(name for name, kind in _PARAMS_TYPES.items() if kind is not None)
        raise TypeError(
            f"the {method!r} method takes no params object (got {type(params).__name__}); "
            f"only {with_params} take one"
        )
    if not isinstance(params, wanted):
        raise TypeError(
            f"params for the {method!r} method must be a {wanted.__name__}, "
            f"got {type(params).__name__}"
        )
