"""The public entry point: ``estimate_transform`` and its registry of methods.

Every method is a function ``(cells1, cells2, *, rng, **options) -> MergeResult``
taking two validated ``int8`` grids. :func:`estimate_transform` validates the
input, dispatches, and fills in what is common to all methods (the transform
in metres, the total time, the empty-map guard).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from merging.grid import OccupancyGrid, occupied_mask, validate_cells
from merging.result import MergeResult
from merging.transforms import cells_to_metres

DEFAULT_METHOD = "tomographic"
"""The method :func:`estimate_transform` uses unless told otherwise."""
MIN_OCCUPIED_CELLS = 10
"""Fewer occupied cells than this in either map cannot fix a rigid transform."""

RngLike = np.random.Generator | int | None


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


_METHODS: dict[str, MergeMethod] = {}


def register_method(name: str) -> Callable[[MergeMethod], MergeMethod]:
    """Decorator registering a merging method under ``name``."""

    def decorate(function: MergeMethod) -> MergeMethod:
        if name in _METHODS:
            raise ValueError(f"a merging method named {name!r} is already registered")
        _METHODS[name] = function
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
    if not isinstance(method, str) or method not in _METHODS:
        raise ValueError(
            f"unknown merging method {method!r}; choose one of: {', '.join(available_methods())}"
        )
    return method


def estimate_transform(
    map1: OccupancyGrid | NDArray[Any],
    map2: OccupancyGrid | NDArray[Any],
    *,
    method: str = DEFAULT_METHOD,
    rng: RngLike = None,
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
        For input that is not a grid in the ROS coding, or grids of different
        resolutions.

    References
    ----------
    .. [1] H. Lee, "Tomographic Feature-Based Map Merging for Multi-Robot
       Systems", Electronics 2020, 9(1), 107.
    """
    start = time.perf_counter()
    cells1 = validate_cells(map1, name="map1")
    cells2 = validate_cells(map2, name="map2")
    check_method(method)
    both_grids = isinstance(map1, OccupancyGrid) and isinstance(map2, OccupancyGrid)
    if both_grids and not np.isclose(map1.resolution, map2.resolution):  # type: ignore[union-attr]
        raise ValueError(
            f"map resolutions differ ({map1.resolution} m vs {map2.resolution} m); "  # type: ignore[union-attr]
            "resample one map to the other's resolution first"
        )
    generator = np.random.default_rng(rng)
    counts = (int(occupied_mask(cells1).sum()), int(occupied_mask(cells2).sum()))
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
    timings = dict(result.timings)
    timings["total"] = time.perf_counter() - start
    metres = cells_to_metres(result.matrix, map1, map2) if both_grids else None  # type: ignore[arg-type]
    return MergeResult(
        matrix=result.matrix,
        confidence=float(np.clip(result.confidence, 0.0, 1.0)),
        accepted=bool(result.accepted),
        method=method,
        matrix_metres=metres,
        hypotheses=result.hypotheses,
        timings=timings,
        reason=result.reason,
    )
