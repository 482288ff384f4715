"""The :class:`World`: wall geometry, ground-truth grid and free-space sampling.

Conventions
-----------
* World frame: metres, ``x`` right, ``y`` up, angles counter-clockwise in
  radians. A pose is ``(x, y, theta)``.
* ``walls`` are line segments of zero thickness, a ``(N, 2, 2)`` float array
  ``walls[i] = [[x0, y0], [x1, y1]]``. They are what physics collides with and
  what the lidar sees; they bound the occupied regions of the truth grid.
* ``truth`` is an :class:`~merging.grid.OccupancyGrid` in the world frame
  (row 0 at the origin, ROS coding). Its free cells are the space robots may
  occupy.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import ndimage

from merging.grid import OccupancyGrid
from merging.validators import RngLike, as_generator

SAMPLING_BATCH = 64
"""Candidate positions drawn at once when sampling a pose."""
MAX_SAMPLING_BATCHES = 100
"""Batches drawn for one pose before sampling gives up."""
MIN_SPACE_WIDTH = 0.2
"""Metres: free strands narrower than this are not counted as explorable space. Maps
built by SLAM hold long strands one or two cells wide where the mapping lidar's beams
left through open doors and windows (on ``aces3`` they are 28 % of the free cells);
no robot can enter them and a lidar sees into them only by a beam exactly along one,
while the narrowest real gaps robots map (doorways, 0.6 m and more) are three times
wider."""


class NoRoomError(ValueError):
    """Fewer poses than asked for fit in a world at the required separation."""

    def __init__(self, message: str, *, placed: int, requested: int) -> None:
        super().__init__(message)
        self.placed = placed
        self.requested = requested


def as_segments(walls: ArrayLike, *, name: str = "walls") -> NDArray[np.float64]:
    """Check and return wall segments as a read-only ``(N, 2, 2)`` float array."""
    segments = np.array(walls, dtype=np.float64)
    if segments.size == 0:
        segments = segments.reshape(0, 2, 2)
    if segments.ndim != 3 or segments.shape[1:] != (2, 2):
        raise ValueError(
            f"{name} must have shape (N, 2, 2) (segments of two (x, y) points), "
            f"got shape {segments.shape}"
        )
    if not np.all(np.isfinite(segments)):
        raise ValueError(f"{name} contains NaN or infinite coordinates")
    segments.setflags(write=False)
    return segments


@dataclass(frozen=True)
class World:
    """A static environment: walls for physics and the lidar, and its true map.

    Parameters
    ----------
    walls : (N, 2, 2) float ndarray
        Wall segments in metres (world frame).
    truth : OccupancyGrid
        Ground-truth grid in the world frame: free cells are where robots may
        be, occupied cells are walls and clutter, unknown cells lie outside
        the building.
    name : str
        A short description (``"floorplan seed=3"``, a map file name).
    """

    walls: NDArray[np.float64]
    truth: OccupancyGrid
    name: str = "world"

    def __post_init__(self) -> None:
        object.__setattr__(self, "walls", as_segments(self.walls))
        if not isinstance(self.truth, OccupancyGrid):
            raise TypeError(f"truth must be an OccupancyGrid, got {type(self.truth).__name__}")

    @property
    def resolution(self) -> float:
        """Edge of a truth-grid cell in metres."""
        return self.truth.resolution

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """``(xmin, ymin, xmax, ymax)`` in metres of the walls and the truth grid together."""
        rows, cols = self.truth.shape
        corners = self.truth.cell_to_world(
            [[-0.5, -0.5], [cols - 0.5, -0.5], [-0.5, rows - 0.5], [cols - 0.5, rows - 0.5]]
        )
        points = np.vstack([corners, self.walls.reshape(-1, 2)])
        low, high = points.min(axis=0), points.max(axis=0)
        return float(low[0]), float(low[1]), float(high[0]), float(high[1])

    @cached_property
    def free(self) -> NDArray[np.bool_]:
        """``(rows, cols)`` mask of the truth grid's free cells."""
        return self.truth.free()

    @cached_property
    def clearance(self) -> NDArray[np.float64]:
        """``(rows, cols)`` distance in metres from each free cell's centre to the
        nearest non-free cell's centre (0 on non-free cells)."""
        padded = np.pad(self.free, 1, constant_values=False)
        distance = ndimage.distance_transform_edt(padded)[1:-1, 1:-1]
        return np.asarray(distance, dtype=np.float64) * self.resolution

    def clearance_at(self, points: ArrayLike) -> NDArray[np.float64]:
        """Clearance (metres) of the truth cell under each of ``(N, 2)`` points; 0 off the grid."""
        cells = np.rint(self.truth.world_to_cell(points)).astype(np.intp)
        rows, cols = self.truth.shape
        inside = (
            (cells[:, 0] >= 0) & (cells[:, 0] < cols) & (cells[:, 1] >= 0) & (cells[:, 1] < rows)
        )
        out = np.zeros(len(cells))
        out[inside] = self.clearance[cells[inside, 1], cells[inside, 0]]
        return out

    @cached_property
    def explorable(self) -> NDArray[np.bool_]:
        """``(rows, cols)`` mask of the free space exploration is measured against.

        The largest 8-connected region of the free cells that remain after a
        morphological opening with a disc of diameter :data:`MIN_SPACE_WIDTH`
        (strands narrower than that removed). On generated floors it differs
        from :meth:`navigable` ``(0)`` only by a few corner cells.
        """
        radius = max(1, round(0.5 * MIN_SPACE_WIDTH / self.resolution))
        y, x = np.ogrid[-radius : radius + 1, -radius : radius + 1]
        disc = x * x + y * y <= radius * radius
        opened = ndimage.binary_opening(self.free, structure=disc)
        labels, count = ndimage.label(opened, structure=np.ones((3, 3), dtype=bool))
        if count == 0:
            return np.asarray(opened)
        sizes = np.bincount(labels.ravel())
        sizes[0] = 0
        return np.asarray(labels == int(np.argmax(sizes)))

    def navigable(self, clearance: float) -> NDArray[np.bool_]:
        """Mask of cells with at least ``clearance`` metres of room, in the largest
        8-connected region of such cells (so any two of them are joined by a path)."""
        if not (np.isfinite(clearance) and clearance >= 0):
            raise ValueError(f"clearance must be a non-negative number of metres, got {clearance}")
        roomy = self.clearance >= max(clearance, self.resolution)
        labels, count = ndimage.label(roomy, structure=np.ones((3, 3), dtype=bool))
        if count == 0:
            return roomy
        sizes = np.bincount(labels.ravel())
        sizes[0] = 0
        return np.asarray(labels == int(np.argmax(sizes)))

    def sample_free_poses(
        self,
        count: int,
        *,
        clearance: float,
        min_separation: float = 0.0,
        rng: RngLike = None,
    ) -> NDArray[np.float64]:
        """Draw ``count`` random poses in one connected free region.

        Parameters
        ----------
        count : int
            Number of poses.
        clearance : float
            Metres of free space required around each position (e.g. the robot
            radius plus a margin).
        min_separation : float
            Least distance in metres between any two returned positions.
        rng : numpy.random.Generator, int or None
            Source of randomness.

        Returns
        -------
        (count, 3) float ndarray
            Poses ``(x, y, theta)``, ``theta`` uniform in ``[-pi, pi)``.

        Raises
        ------
        ValueError
            If the world has no room with that clearance; :class:`NoRoomError`
            (a ValueError) if the poses cannot be kept ``min_separation`` apart.
        """
        if count < 0:
            raise ValueError(f"count must be non-negative, got {count}")
        generator = as_generator(rng)
        rows, cols = np.nonzero(self.navigable(clearance))
        if len(rows) == 0:
            raise ValueError(
                f"no free region in {self.name!r} has {clearance} m of clearance (room to "
                "place a robot); use a roomier world (or, placing poses yourself, a smaller "
                "clearance)"
            )
        poses = np.zeros((count, 3))
        for chosen in range(count):
            for _ in range(MAX_SAMPLING_BATCHES):
                picks = generator.integers(len(rows), size=SAMPLING_BATCH)
                candidates = self.truth.cell_to_world(np.column_stack([cols[picks], rows[picks]]))
                if chosen:
                    gaps = np.hypot(
                        *(candidates[:, None, :] - poses[None, :chosen, :2]).transpose(2, 0, 1)
                    )
                    good = np.flatnonzero(np.all(gaps >= min_separation, axis=1))
                else:
                    good = np.arange(SAMPLING_BATCH)
                if len(good):
                    poses[chosen, :2] = candidates[good[0]]
                    poses[chosen, 2] = generator.uniform(-np.pi, np.pi)
                    break
            else:
                raise NoRoomError(
                    f"could only place {chosen} of {count} poses {min_separation} m "
                    f"apart in {self.name!r}; lower min_separation or the count",
                    placed=chosen,
                    requested=count,
                )
        return poses
