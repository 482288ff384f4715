"""Drawing the layout of an office floor: building outline, corridors, rooms and doors.

All geometry is in metres in the building frame (lower-left corner of the
building's bounding box at the origin). The steps:

1. a main corridor crosses the building along ``x`` at a random height;
2. a corner of the building may be cut away (a *notch*), making it L-shaped;
3. a side corridor may run from the main corridor to one outer wall;
4. the bands left on either side of the corridors are cut into rooms of
   random widths, deep rooms sometimes into a front and a back room;
5. every room gets a door to the corridor (back rooms to their front room),
   and some neighbouring rooms get a door between them.

The random corridor height, notch and side corridor make the plan
non-symmetric.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np

from tomosim.worlds.floorplan_config import FloorplanConfig

Rect = tuple[float, float, float, float]
"""An axis-aligned box ``(x0, y0, x1, y1)`` in metres, ``x0 < x1``, ``y0 < y1``."""

NOTCH_MIN_DEPTH = 1.5
"""Least depth (m) of a notch that leaves rooms behind it; shallower ones are not drawn."""
NOTCH_WIDTH_FRACTION = (0.2, 0.4)
"""Range of the notch's width as a fraction of the building's width."""
CORRIDOR_HEIGHT_FRACTION = (0.3, 0.7)
"""Range of the main corridor's centre height as a fraction of the building's height."""
SIDE_CORRIDOR_FRACTION = (0.15, 0.85)
"""Range of the side corridor's position as a fraction of the building's width."""
SIDE_CORRIDOR_TRIES = 20
"""Positions drawn for the side corridor before doing without one."""
DOOR_END_MARGIN = 0.3
"""Metres between a door and the wall that ends its edge (beyond the wall's half thickness)."""
MIN_ROOM_WIDTH = 1.5
"""Blocks narrower than this (m) are filled solid rather than made into closets."""


@dataclass(slots=True)
class Layout:
    """The plan of a floor, before rasterisation.

    Attributes
    ----------
    outline : Rect
        The building's bounding box.
    notch : Rect or None
        A cut-away corner of ``outline`` that is outside the building.
    corridors, rooms : list of Rect
        Open spaces; every room and corridor is enclosed by walls on its edges.
    solid : list of Rect
        Slivers too narrow for a room, filled as wall.
    doors : list of Rect
        Openings cut through walls, already spanning the wall's thickness.
    """

    outline: Rect
    notch: Rect | None = None
    corridors: list[Rect] = field(default_factory=list)
    rooms: list[Rect] = field(default_factory=list)
    solid: list[Rect] = field(default_factory=list)
    doors: list[Rect] = field(default_factory=list)


def _door(
    layout: Layout,
    config: FloorplanConfig,
    rng: np.random.Generator,
    *,
    axis: str,
    at: float,
    span: tuple[float, float],
    required: bool = False,
) -> None:
    """Cut a door through the wall on the line ``y = at`` (axis ``"x"``) or ``x = at``.

    A door that does not fit with :data:`DOOR_END_MARGIN` at both ends is left out,
    unless it is ``required`` (a room's only way in): it is then centred on the span,
    as wide as drawn or as the span between the end walls allows, so that no room is
    sealed (blocks down to :data:`MIN_ROOM_WIDTH` are made into rooms).
    """
    half_t = 0.5 * config.wall_thickness
    width = rng.uniform(*config.door_width)
    low = span[0] + half_t + DOOR_END_MARGIN
    high = span[1] - half_t - DOOR_END_MARGIN - width
    if high >= low:
        start = rng.uniform(low, high)
    elif required and span[1] - span[0] > 2.0 * half_t:
        width = min(width, span[1] - span[0] - 2.0 * half_t)
        start = 0.5 * (span[0] + span[1] - width)
    else:
        return
    depth = half_t + config.resolution
    if axis == "x":
        layout.doors.append((start, at - depth, start + width, at + depth))
    else:
        layout.doors.append((at - depth, start, at + depth, start + width))


def _split_widths(
    x0: float, x1: float, config: FloorplanConfig, rng: np.random.Generator
) -> list[float]:
    """Cut ``[x0, x1]`` into room widths drawn from ``config.room_width``; returns the cuts."""
    low, high = config.room_width
    cuts, x = [x0], x0
    while x1 - x > high:
        width = rng.uniform(low, high)
        if x1 - (x + width) < low:
            width = 0.5 * (x1 - x)
        x += width
        cuts.append(x)
    cuts.append(x1)
    return cuts


def _fill_block(
    layout: Layout,
    block: Rect,
    corridor_y: float,
    config: FloorplanConfig,
    rng: np.random.Generator,
) -> list[tuple[Rect, Rect | None]]:
    """Cut a block beside the main corridor into rooms; returns ``(front, back)`` pairs."""
    x0, y0, x1, y1 = block
    if x1 - x0 < MIN_ROOM_WIDTH:
        layout.solid.append(block)
        return []
    faces_up = corridor_y >= y1 - 1e-9
    columns: list[tuple[Rect, Rect | None]] = []
    cuts = _split_widths(x0, x1, config, rng)
    for left, right in itertools.pairwise(cuts):
        depth = y1 - y0
        back: Rect | None = None
        front: Rect = (left, y0, right, y1)
        if depth >= 2 * config.min_room_depth and rng.random() < config.split_probability:
            cut = rng.uniform(config.min_room_depth, depth - config.min_room_depth)
            line = y1 - cut if faces_up else y0 + cut
            front = (left, line, right, y1) if faces_up else (left, y0, right, line)
            back = (left, y0, right, line) if faces_up else (left, line, right, y1)
            layout.rooms.append(back)
            _door(layout, config, rng, axis="x", at=line, span=(left, right), required=True)
        layout.rooms.append(front)
        _door(layout, config, rng, axis="x", at=corridor_y, span=(left, right), required=True)
        columns.append((front, back))
    for (a_front, a_back), (b_front, b_back) in itertools.pairwise(columns):
        for a, b in ((a_front, b_front), (a_back, b_back)):
            if a is None or b is None or rng.random() >= config.extra_door_probability:
                continue
            low, high = max(a[1], b[1]), min(a[3], b[3])
            _door(layout, config, rng, axis="y", at=a[2], span=(low, high))
    return columns


def draw_layout(config: FloorplanConfig, rng: np.random.Generator) -> Layout:
    """Draw a random floor plan following the steps in the module docstring."""
    width, height = config.width, config.height
    layout = Layout(outline=(0.0, 0.0, width, height))
    # 1. The main corridor, off the middle.
    wc = rng.uniform(*config.corridor_width)
    low = max(config.min_room_depth + 0.5 * wc, CORRIDOR_HEIGHT_FRACTION[0] * height)
    high = min(height - config.min_room_depth - 0.5 * wc, CORRIDOR_HEIGHT_FRACTION[1] * height)
    yc = rng.uniform(low, high) if high > low else 0.5 * height
    main: Rect = (0.0, yc - 0.5 * wc, width, yc + 0.5 * wc)
    layout.corridors.append(main)
    bands = {"bottom": (0.0, main[1]), "top": (main[3], height)}
    # 2. A notch cut from one corner.
    notch_side = None
    if rng.random() < config.notch_probability:
        notch_side = "bottom" if rng.random() < 0.5 else "top"
        b0, b1 = bands[notch_side]
        depth = b1 - b0
        nh = depth
        if depth - config.min_room_depth >= NOTCH_MIN_DEPTH and rng.random() < 0.5:
            nh = rng.uniform(NOTCH_MIN_DEPTH, depth - config.min_room_depth)
        nw = rng.uniform(*NOTCH_WIDTH_FRACTION) * width
        nx0, nx1 = (0.0, nw) if rng.random() < 0.5 else (width - nw, width)
        ny0, ny1 = (0.0, nh) if notch_side == "bottom" else (height - nh, height)
        layout.notch = (nx0, ny0, nx1, ny1)
    # 3. A side corridor from the main corridor to one outer wall.
    side = None
    side_x: tuple[float, float] = (0.0, 0.0)
    if rng.random() < config.side_corridor_probability:
        side = "bottom" if rng.random() < 0.5 else "top"
        ws = rng.uniform(*config.corridor_width)
        for _ in range(SIDE_CORRIDOR_TRIES):
            xs = rng.uniform(*SIDE_CORRIDOR_FRACTION) * width
            side_x = (xs - 0.5 * ws, xs + 0.5 * ws)
            if layout.notch is None or notch_side != side:
                break
            keep_out = config.room_width[0]
            if side_x[1] + keep_out < layout.notch[0] or side_x[0] - keep_out > layout.notch[2]:
                break
        else:
            side = None
        if side is not None:
            b0, b1 = bands[side]
            layout.corridors.append((side_x[0], b0, side_x[1], b1))
    # 4.-5. Rooms and doors in each band, block by block.
    for name, (b0, b1) in bands.items():
        corridor_y = b1 if name == "bottom" else b0
        cuts = {0.0, width}
        if side == name:
            cuts |= {side_x[0], side_x[1]}
        if layout.notch is not None and notch_side == name:
            cuts |= {layout.notch[0], layout.notch[2]}
        edges = sorted(cuts)
        for x0, x1 in itertools.pairwise(edges):
            if side == name and x0 >= side_x[0] - 1e-9 and x1 <= side_x[1] + 1e-9:
                continue
            y0, y1 = b0, b1
            notch = layout.notch
            if (
                notch is not None
                and notch_side == name
                and x0 >= notch[0] - 1e-9
                and x1 <= notch[2] + 1e-9
            ):
                y0, y1 = (notch[3], b1) if name == "bottom" else (b0, notch[1])
                if y1 - y0 < config.min_room_depth - 1e-9:
                    continue
            columns = _fill_block(layout, (x0, y0, x1, y1), corridor_y, config, rng)
            if side == name and columns:
                # Rooms beside the side corridor may open onto it.
                for front, back in columns:
                    for room in (front, back):
                        if room is None or rng.random() >= config.side_door_probability:
                            continue
                        for edge in (room[0], room[2]):
                            if abs(edge - side_x[0]) < 1e-9 or abs(edge - side_x[1]) < 1e-9:
                                _door(
                                    layout, config, rng, axis="y", at=edge, span=(room[1], room[3])
                                )
    return layout
