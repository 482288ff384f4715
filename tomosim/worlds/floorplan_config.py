"""Configuration of the procedural floor-plan generator."""

from __future__ import annotations

from dataclasses import dataclass

from merging.validators import real_number

MIN_EXTENT_ROOMS = 2
"""The building must be at least this many smallest rooms wide."""
MAX_SIDE_CELLS = 20000
"""Most cells a side of a floor's truth grid (a 1000 m floor at 0.05 m); a
grid of 20000 x 20000 cells takes 400 MB and its walls minutes to build."""


@dataclass(frozen=True)
class FloorplanConfig:
    """Parameters of :func:`~tomosim.worlds.generate_floorplan`; lengths in metres.

    Ranges ``(low, high)`` are drawn uniformly. The defaults give an office
    floor of about 30 m x 20 m with rooms of 3-6.5 m, 1.6-2.4 m corridors and
    0.9-1.3 m doors.
    """

    width: float = 30.0
    height: float = 20.0
    resolution: float = 0.05
    margin: float = 1.0
    """Unknown border around the building in the truth grid."""
    wall_thickness: float = 0.15
    corridor_width: tuple[float, float] = (1.6, 2.4)
    room_width: tuple[float, float] = (3.0, 6.5)
    """Extent of a room along the corridor it opens onto."""
    min_room_depth: float = 3.0
    door_width: tuple[float, float] = (0.9, 1.3)
    split_probability: float = 0.5
    """Chance that a room deeper than twice ``min_room_depth`` is split front/back."""
    extra_door_probability: float = 0.35
    """Chance of a door between two neighbouring rooms."""
    side_door_probability: float = 0.5
    """Chance that a room beside the side corridor opens onto it."""
    notch_probability: float = 0.75
    """Chance that a corner of the building is cut away."""
    side_corridor_probability: float = 0.8
    clutter_per_room: tuple[int, int] = (0, 3)
    """Least and most pieces of furniture per room (inclusive)."""
    clutter_length: tuple[float, float] = (0.5, 1.6)
    clutter_width: tuple[float, float] = (0.4, 0.9)
    robot_clearance: float = 0.3
    """Clutter never cuts the free space apart for a disc of this radius."""

    def __post_init__(self) -> None:
        for name, value in vars(self).items():
            if isinstance(value, tuple) and len(value) != 2:
                raise ValueError(f"{name} must be a range (low, high), got {value!r}")
            for number in value if isinstance(value, tuple) else (value,):
                real_number(number, name)
        for name in (
            "width",
            "height",
            "resolution",
            "wall_thickness",
            "min_room_depth",
            "robot_clearance",
        ):
            real_number(getattr(self, name), name, low=0.0, low_open=True, unit="metres")
        if self.resolution > self.wall_thickness:
            raise ValueError(
                f"resolution ({self.resolution} m) must be at most the wall thickness "
                f"({self.wall_thickness} m): a wall thinner than a cell paints no cell, and "
                "rooms run into each other in the grid"
            )
        if self.margin < self.wall_thickness:
            raise ValueError(
                f"margin ({self.margin} m) must be at least the wall thickness "
                f"({self.wall_thickness} m) so outer walls fit in the grid"
            )
        for name in (
            "corridor_width",
            "room_width",
            "door_width",
            "clutter_length",
            "clutter_width",
            "clutter_per_room",
        ):
            low, high = getattr(self, name)
            if not 0 <= low <= high:
                raise ValueError(
                    f"{name} must be a range (low, high) with 0 <= low <= high, got {(low, high)}"
                )
        for name in (
            "split_probability",
            "extra_door_probability",
            "side_door_probability",
            "notch_probability",
            "side_corridor_probability",
        ):
            value = getattr(self, name)
            if not 0 <= value <= 1:
                raise ValueError(f"{name} must be a probability in [0, 1], got {value}")
        for name in ("width", "height"):
            cells = (getattr(self, name) + 2 * self.margin) / self.resolution
            if cells > MAX_SIDE_CELLS:
                raise ValueError(
                    f"{name} {getattr(self, name)} m makes a grid {cells:.0f} cells a side at "
                    f"{self.resolution} m a cell, more than {MAX_SIDE_CELLS}; use a smaller "
                    "floor (or a coarser FloorplanConfig.resolution)"
                )
        if self.width < MIN_EXTENT_ROOMS * self.room_width[0]:
            raise ValueError(
                f"width {self.width} m is too small: use at least "
                f"{MIN_EXTENT_ROOMS * self.room_width[0]} m (two rooms)"
            )
        least_height = 2 * self.min_room_depth + self.corridor_width[1]
        if self.height < least_height:
            raise ValueError(
                f"height {self.height} m is too small: use at least {least_height} m "
                "(a room on each side of the widest corridor)"
            )
        if self.corridor_width[0] <= 2 * self.robot_clearance:
            raise ValueError(
                f"corridors ({self.corridor_width[0]} m) must be wider than a robot "
                f"({2 * self.robot_clearance} m)"
            )
        if self.door_width[0] <= 2 * self.robot_clearance:
            raise ValueError(
                f"doors ({self.door_width[0]} m) must be wider than a robot "
                f"({2 * self.robot_clearance} m)"
            )
