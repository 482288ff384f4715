"""The occupancy-grid type and the cell coding every part of tomosim shares.

Conventions (pinned by ``tests/merging/test_grid.py``):

* ``data`` is a 2-D ``int8`` array indexed ``[row, col]`` in the ROS
  ``nav_msgs/OccupancyGrid`` coding: ``-1`` unknown, ``0..100`` occupancy
  probability in percent.
* Row 0 is the row nearest the map origin (the *bottom* of the picture a
  ``map_server`` PNG shows), so cell coordinates ``(x, y) = (col, row)`` form a
  right-handed frame with angles counter-clockwise, like the world frame.
* A cell is *occupied* at ``>= 65`` and *free* at ``<= 19`` (``map_server``'s
  thresholds 0.65 and 0.196, applied to percent values).
* The centre of cell ``(x, y)`` lies at ``origin + R(yaw) @ ((x + 0.5) * res,
  (y + 0.5) * res)`` metres in the map frame, as in ROS.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from merging.validators import real_number

UNKNOWN = -1
"""Cell value for an unobserved cell."""
FREE = 0
"""Cell value written for a certainly free cell."""
OCCUPIED = 100
"""Cell value written for a certainly occupied cell."""
OCCUPIED_THRESHOLD = 65
"""A cell is occupied at this value or above (``map_server`` occupied_thresh 0.65)."""
FREE_THRESHOLD = 19
"""A cell is free at this value or below (``map_server`` free_thresh 0.196 is 19.6 %)."""


def validate_cells(cells: object, *, name: str = "map") -> NDArray[np.int8]:
    """Check that ``cells`` is a grid in the ROS coding and return it as ``int8``.

    Parameters
    ----------
    cells : array_like or OccupancyGrid
        A 2-D array of cell values in ``{-1} U [0, 100]``. Integer arrays and
        float arrays holding whole numbers are accepted.
    name : str
        How the value is called in error messages.

    Returns
    -------
    (rows, cols) int8 ndarray
        The same values; a copy only when the dtype had to change.

    Raises
    ------
    TypeError
        If ``cells`` is not an array (or an ``OccupancyGrid``) of numbers, or is a
        masked array (its mask would be ignored).
    ValueError
        If it is not 2-D, holds NaN or infinities, fractional values, or
        values outside the coding.
    """
    if isinstance(cells, OccupancyGrid):
        return cells.data
    if not isinstance(cells, np.ndarray):
        raise TypeError(
            f"{name} must be a numpy array or an OccupancyGrid, got {type(cells).__name__}"
        )
    if isinstance(cells, np.ma.MaskedArray):
        raise TypeError(
            f"{name} is a masked array, whose mask the merger would not see; fill the "
            f"masked cells with the unknown value first: {name}.filled(-1)"
        )
    if cells.dtype == np.bool_ or not np.issubdtype(cells.dtype, np.number):
        raise TypeError(
            f"{name} must hold numbers in the ROS coding (-1 unknown, 0..100), "
            f"got dtype {cells.dtype}; convert boolean masks with OccupancyGrid.from_bool"
        )
    if cells.ndim != 2:
        raise ValueError(f"{name} must be 2-D, got shape {cells.shape}")
    if cells.size == 0:
        raise ValueError(f"{name} must have at least one cell, got shape {cells.shape}")
    if np.issubdtype(cells.dtype, np.complexfloating):
        raise TypeError(f"{name} must be real-valued, got dtype {cells.dtype}")
    if np.issubdtype(cells.dtype, np.floating):
        if not np.all(np.isfinite(cells)):
            raise ValueError(f"{name} contains NaN or infinite values; mark unknown cells -1")
        if np.any(cells != np.round(cells)):
            raise ValueError(
                f"{name} holds fractional values; use OccupancyGrid.from_probability "
                "for probabilities in [0, 1]"
            )
    low, high = cells.min(), cells.max()
    if low < UNKNOWN or high > OCCUPIED:
        hint = ""
        if low >= 0 and high <= 255:
            hint = (
                "; pixels of a map_server image? load its .yaml with merging.load_map; "
                "a nav_msgs grid read as unsigned bytes holds 255 for unknown: view it "
                "as int8 (cells.astype(np.int8))"
            )
        raise ValueError(
            f"{name} values must lie in -1..100 (ROS coding), got range [{low}, {high}]{hint}"
        )
    if (
        np.issubdtype(cells.dtype, np.floating)
        and high == 1
        and not np.any((cells != UNKNOWN) & (cells != 0) & (cells != 1))
    ):
        # Grids the library makes are int8; a float array of 0 and 1 is a mask or
        # probabilities far more often than percentages that happen to stay below 2.
        raise ValueError(
            f"{name} is a float array of only 0 and 1 (and -1), which the ROS coding reads "
            "as free everywhere (100 is occupied); a mask or probabilities? use "
            "OccupancyGrid.from_bool or OccupancyGrid.from_probability"
        )
    if cells.dtype == np.int8:
        return cells
    return cells.astype(np.int8)


MAX_ORIGIN_METRES = 1e9
"""Farthest a grid's origin may lie from its frame's zero (x and y): a million
kilometres is a unit mistake, and past about 1e15 m a float no longer tells cells of
0.05 m apart (origins of 1e308 m made the transform in metres NaN)."""


@dataclass(frozen=True, slots=True)
class OccupancyGrid:
    """An occupancy grid in the ROS coding, with its place in the world.

    Parameters
    ----------
    data : (rows, cols) int8 ndarray
        Cell values, ``-1`` unknown, ``0..100`` percent occupied; row 0 nearest
        the origin.
    resolution : float
        Edge length of a cell in metres.
    origin : (float, float, float)
        ``(x, y, yaw)`` of the corner of cell ``(0, 0)`` in the map frame,
        metres and radians.
    """

    data: NDArray[np.int8]
    resolution: float = 0.05
    origin: tuple[float, float, float] = field(default=(0.0, 0.0, 0.0))

    def __post_init__(self) -> None:
        object.__setattr__(self, "data", validate_cells(self.data, name="data"))
        resolution = real_number(
            self.resolution, "resolution", low=0.0, low_open=True, unit="metres"
        )
        object.__setattr__(self, "resolution", resolution)
        origin = self.origin
        message = f"origin must be three finite numbers (x, y, yaw), got {origin!r}"
        if not (isinstance(origin, tuple | list | np.ndarray) and len(origin) == 3):
            raise ValueError(message)
        try:
            values = tuple(real_number(v, "origin") for v in origin)
        except ValueError:
            raise ValueError(message) from None
        if max(abs(values[0]), abs(values[1])) > MAX_ORIGIN_METRES:
            raise ValueError(
                f"origin {origin!r} lies more than {MAX_ORIGIN_METRES:g} m from its frame's "
                "zero; give it in metres"
            )
        object.__setattr__(self, "origin", values)

    @classmethod
    def from_bool(
        cls,
        occupied: ArrayLike,
        free: ArrayLike | None = None,
        *,
        resolution: float = 0.05,
        origin: tuple[float, float, float] = (0.0, 0.0, 0.0),
    ) -> OccupancyGrid:
        """Build a grid from boolean masks.

        ``occupied`` cells become 100. If ``free`` is given, its cells become 0
        and all others unknown; if it is omitted, every non-occupied cell is free.
        """
        occ = np.asarray(occupied)
        if occ.dtype != np.bool_:
            raise TypeError(f"occupied must be a boolean array, got dtype {occ.dtype}")
        if occ.ndim != 2:
            raise ValueError(f"occupied must be 2-D, got shape {occ.shape}")
        if free is None:
            data = np.where(occ, OCCUPIED, FREE).astype(np.int8)
        else:
            fr = np.asarray(free)
            if fr.dtype != np.bool_ or fr.shape != occ.shape:
                raise ValueError(
                    f"free must be a boolean array of shape {occ.shape}, "
                    f"got dtype {fr.dtype} shape {fr.shape}"
                )
            data = np.full(occ.shape, UNKNOWN, dtype=np.int8)
            data[fr] = FREE
            data[occ] = OCCUPIED
        return cls(data, resolution=resolution, origin=origin)

    @classmethod
    def from_probability(
        cls,
        probability: ArrayLike,
        *,
        resolution: float = 0.05,
        origin: tuple[float, float, float] = (0.0, 0.0, 0.0),
    ) -> OccupancyGrid:
        """Build a grid from occupancy probabilities in ``[0, 1]``; NaN means unknown."""
        prob = np.asarray(probability, dtype=float)
        if prob.ndim != 2:
            raise ValueError(f"probability must be 2-D, got shape {prob.shape}")
        known = ~np.isnan(prob)  # an infinity is a probability out of range, not unknown
        if np.any(known & ((prob < 0) | (prob > 1))):
            raise ValueError(
                f"probabilities must lie in [0, 1] (NaN for unknown), "
                f"got range [{np.nanmin(prob)}, {np.nanmax(prob)}]"
            )
        data = np.full(prob.shape, UNKNOWN, dtype=np.int8)
        data[known] = np.rint(prob[known] * 100).astype(np.int8)
        return cls(data, resolution=resolution, origin=origin)

    @property
    def shape(self) -> tuple[int, int]:
        """``(rows, cols)`` of the grid."""
        return (int(self.data.shape[0]), int(self.data.shape[1]))

    def occupied(self) -> NDArray[np.bool_]:
        """Boolean mask of occupied cells (value ``>= 65``)."""
        return occupied_mask(self.data)

    def free(self) -> NDArray[np.bool_]:
        """Boolean mask of free cells (``0 <= value <= 19``)."""
        return free_mask(self.data)

    def known(self) -> NDArray[np.bool_]:
        """Boolean mask of observed cells (value ``>= 0``)."""
        return self.data >= 0

    def cell_to_world(self, cells: ArrayLike) -> NDArray[np.float64]:
        """Map ``(N, 2)`` cell coordinates ``(x, y) = (col, row)`` to metres.

        Cell centres lie at integer coordinates; the result is the centre's
        position in the map frame.
        """
        pts = np.atleast_2d(np.asarray(cells, dtype=float))
        return pts @ self.cell_to_world_matrix()[:2, :2].T + self.cell_to_world_matrix()[:2, 2]

    def world_to_cell(self, points: ArrayLike) -> NDArray[np.float64]:
        """Map ``(N, 2)`` map-frame points in metres to fractional cell coordinates."""
        pts = np.atleast_2d(np.asarray(points, dtype=float))
        inverse = np.linalg.inv(self.cell_to_world_matrix())
        return pts @ inverse[:2, :2].T + inverse[:2, 2]

    def cell_to_world_matrix(self) -> NDArray[np.float64]:
        """The 3x3 homogeneous matrix taking cell coordinates to map-frame metres."""
        ox, oy, yaw = self.origin
        c, s = np.cos(yaw), np.sin(yaw)
        res = self.resolution
        rotation = np.array([[c, -s], [s, c]])
        matrix = np.eye(3)
        matrix[:2, :2] = rotation * res
        matrix[:2, 2] = rotation @ np.array([0.5 * res, 0.5 * res]) + np.array([ox, oy])
        return matrix


def occupied_mask(cells: NDArray[np.int8]) -> NDArray[np.bool_]:
    """Cells at or above :data:`OCCUPIED_THRESHOLD`."""
    return cells >= OCCUPIED_THRESHOLD


def free_mask(cells: NDArray[np.int8]) -> NDArray[np.bool_]:
    """Known cells at or below :data:`FREE_THRESHOLD`."""
    return (cells >= 0) & (cells <= FREE_THRESHOLD)


def occupied_cells(cells: NDArray[np.int8]) -> NDArray[np.float64]:
    """``(N, 2)`` float array of the ``(x, y) = (col, row)`` coordinates of occupied cells."""
    rows, cols = np.nonzero(occupied_mask(cells))
    return np.column_stack([cols, rows]).astype(np.float64)


def observed_part(cells: NDArray[np.int8]) -> tuple[NDArray[np.int8], NDArray[np.float64]]:
    """The smallest box of ``cells`` holding every observed cell, and its corner ``(x, y)``.

    A grid with no observed cell is returned whole, at ``(0, 0)``.
    """
    known = cells >= 0
    rows = np.flatnonzero(known.any(axis=1))
    cols = np.flatnonzero(known.any(axis=0))
    if len(rows) == 0:
        return cells, np.zeros(2)
    box = cells[rows[0] : rows[-1] + 1, cols[0] : cols[-1] + 1]
    return box, np.array([cols[0], rows[0]], dtype=float)
