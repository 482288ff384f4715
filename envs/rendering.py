"""Frames of a team exploring: ground truth, team knowledge, merged map, robots.

One pixel per truth cell, ``y`` up (the truth grid's top row at the top of the
image):

* the ground truth in map_server greys (free white, occupied black, unknown grey);
* free space the team has observed, tinted blue;
* the walls of the latest merged map, placed in the world by its reference
  robot's true start pose, in magenta: where they miss the black walls of the
  truth, the merge (or the odometry) is off;
* each robot as a disc in its colour with a heading tick, at its true pose.

:func:`render_frame` returns the frame (``render_mode="rgb_array"``);
:class:`HumanWindow` shows it in a matplotlib window (``render_mode="human"``).
A window needs a display: where there is none (matplotlib falls back to its
``Agg`` backend, as on a server or in CI) the frames are drawn into an
off-screen figure, :attr:`HumanWindow.figure`, which can be saved, and no
window opens.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from merging.grid import UNKNOWN, OccupancyGrid
from tomosim.frames import pose_matrix
from tomosim.team import TeamSession

FREE_GREY, OCCUPIED_GREY, UNKNOWN_GREY = 254, 0, 205
"""map_server's pixel values for free, occupied and unknown cells."""
KNOWN_TINT = np.array([120, 170, 255], dtype=np.float64)
"""RGB blended over free cells the team knows."""
KNOWN_TINT_WEIGHT = 0.35
"""Weight of :data:`KNOWN_TINT` in the blend."""
MERGED_WALL = np.array([200, 0, 200], dtype=np.uint8)
"""RGB of the merged map's occupied cells: magenta, a colour no robot is drawn in
(the recordings draw merged walls in it too)."""
ROBOT_COLOURS = np.array(
    [
        [31, 119, 180],
        [255, 127, 14],
        [44, 160, 44],
        [214, 39, 40],
        [148, 103, 189],
        [140, 86, 75],
        [227, 119, 194],
        [23, 190, 207],
    ],
    dtype=np.uint8,
)
"""RGB of robot ``k`` is row ``k % 8`` (the colours the recordings use)."""
HEADING_LENGTH_RADII = 2.0
"""Length of the heading tick in robot radii."""


def grid_in_truth(
    grid: OccupancyGrid, world_from_grid: NDArray[np.float64], truth: OccupancyGrid
) -> NDArray[np.int8]:
    """``grid`` resampled onto the truth grid's cells (nearest cell), unknown off the grid.

    ``world_from_grid`` is the rigid matrix taking the grid's frame to the world.
    """
    # truth cell (x, y) -> grid cell coordinates
    back = (
        np.linalg.inv(grid.cell_to_world_matrix())
        @ np.linalg.inv(world_from_grid)
        @ truth.cell_to_world_matrix()
    )
    matrix = np.array([[back[1, 1], back[1, 0]], [back[0, 1], back[0, 0]]])
    offset = np.array([back[1, 2], back[0, 2]])
    return ndimage.affine_transform(
        grid.data,
        matrix,
        offset=offset,
        output_shape=truth.shape,
        order=0,
        mode="grid-constant",
        cval=UNKNOWN,
        prefilter=False,
    )


def _disc(
    image: NDArray[np.uint8], centre: NDArray[np.float64], radius: float, colour: NDArray[np.uint8]
) -> None:
    """Fill a disc of ``radius`` pixels around ``centre = (col, row)`` (image rows)."""
    rows, cols = image.shape[:2]
    r0, r1 = int(max(centre[1] - radius, 0)), int(min(centre[1] + radius + 1, rows))
    c0, c1 = int(max(centre[0] - radius, 0)), int(min(centre[0] + radius + 1, cols))
    if r0 >= r1 or c0 >= c1:
        return
    yy, xx = np.mgrid[r0:r1, c0:c1]
    inside = (xx - centre[0]) ** 2 + (yy - centre[1]) ** 2 <= radius**2
    image[r0:r1, c0:c1][inside] = colour


def _segment(
    image: NDArray[np.uint8],
    start: NDArray[np.float64],
    end: NDArray[np.float64],
    colour: NDArray[np.uint8],
) -> None:
    """Draw a one-pixel segment between two ``(col, row)`` points."""
    count = int(np.ceil(np.hypot(*(end - start)))) + 1
    points = np.rint(np.linspace(start, end, count)).astype(int)
    rows, cols = image.shape[:2]
    keep = (points[:, 0] >= 0) & (points[:, 0] < cols) & (points[:, 1] >= 0) & (points[:, 1] < rows)
    image[points[keep, 1], points[keep, 0]] = colour


def render_frame(session: TeamSession) -> NDArray[np.uint8]:
    """The ``(rows, cols, 3)`` uint8 frame of the module docstring."""
    truth = session.world.truth
    cells = truth.data
    grey = np.full(cells.shape, UNKNOWN_GREY, dtype=np.float64)
    grey[truth.free()] = FREE_GREY
    grey[truth.occupied()] = OCCUPIED_GREY
    rgb = np.repeat(grey[..., None], 3, axis=2)
    known = session.coverage.known_mask()
    rgb[known] = (1 - KNOWN_TINT_WEIGHT) * rgb[known] + KNOWN_TINT_WEIGHT * KNOWN_TINT
    image = np.clip(np.rint(rgb), 0, 255).astype(np.uint8)
    merge = session.last_merge
    if merge is not None:
        start = session.simulation.start_poses[merge.reference]
        placed = grid_in_truth(merge.merged, pose_matrix(start), truth)
        image[placed >= 65] = MERGED_WALL
    to_cells = np.linalg.inv(truth.cell_to_world_matrix())
    radius = session.config.simulation.physics.robot_radius / truth.resolution
    for k, (x, y, theta) in enumerate(session.simulation.true_poses):
        centre = (to_cells @ np.array([x, y, 1.0]))[:2]
        tip = centre + HEADING_LENGTH_RADII * radius * np.array([np.cos(theta), np.sin(theta)])
        colour = ROBOT_COLOURS[k % len(ROBOT_COLOURS)]
        _disc(image, centre, radius, colour)
        _segment(image, centre, tip, np.zeros(3, dtype=np.uint8))
    return np.ascontiguousarray(image[::-1])


NON_INTERACTIVE_BACKENDS = frozenset({"agg", "cairo", "pdf", "pgf", "ps", "svg", "template"})
"""matplotlib backends that draw files, not windows (lower case)."""
WINDOW_INCHES = 8.0
"""Width of the window in inches; its height follows the world's aspect."""


class HumanWindow:
    """``render_mode="human"``: each frame shown in one matplotlib window (module docstring).

    Parameters
    ----------
    fps : float
        Frames a second the window is refreshed at (each :meth:`show` waits
        ``1 / fps`` s for the window to draw, on an interactive backend).
    title : str
        The window's title.
    """

    __slots__ = ("_image", "figure", "fps", "title")

    def __init__(self, fps: float, title: str) -> None:
        if fps <= 0:
            raise ValueError(f"fps must be positive, got {fps}")
        self.fps = float(fps)
        self.title = title
        self.figure: Any = None
        self._image: Any = None

    @staticmethod
    def interactive() -> bool:
        """Whether matplotlib's backend opens windows (False without a display)."""
        import matplotlib

        return matplotlib.get_backend().lower() not in NON_INTERACTIVE_BACKENDS

    def show(self, frame: NDArray[np.uint8]) -> None:
        """Draw ``frame`` (rows, cols, 3) in the window, opening it on the first call."""
        import matplotlib.pyplot as plt

        if self.figure is None:
            rows, cols = frame.shape[:2]
            size = (WINDOW_INCHES, WINDOW_INCHES * rows / max(cols, 1))
            self.figure, axes = plt.subplots(figsize=size, layout="constrained")
            self.figure.canvas.manager.set_window_title(self.title)
            axes.set_axis_off()
            self._image = axes.imshow(frame, interpolation="nearest")
        else:
            self._image.set_data(frame)
        if self.interactive():
            plt.pause(1.0 / self.fps)  # draws and lets the window handle its events
        else:
            self.figure.canvas.draw()

    def close(self) -> None:
        """Close the window (safe to call twice)."""
        if self.figure is not None:
            import matplotlib.pyplot as plt

            plt.close(self.figure)
            self.figure = None
            self._image = None
