"""How grids look in the viewer: annotation contexts from ROS cell values to colours.

Grids are logged as ``SegmentationImage`` of their ROS cell values (-1 seen
as 255, 0..100 occupancy percent), so the recording keeps every cell exactly
and the viewer colours each value through the annotation context of the
nearest ancestor entity (hovering a cell names it: free, occupied, unknown):

* :func:`map_classes` (the truth and each robot's map): map_server greys,
  free white, occupied black, the values between in grey; unknown cells
  transparent, so the view's background (or the map below) shows through;
* :func:`merged_classes` (the merged map over the truth): free cells a light
  translucent blue, walls an opaque magenta that no robot is drawn in,
  unknown transparent, so that the truth stays visible under the merged map
  and a misplaced merged wall stands out against the truth's black ones.
"""

from __future__ import annotations

import rerun as rr

from merging.grid import FREE_THRESHOLD, OCCUPIED, OCCUPIED_THRESHOLD

UNKNOWN_CLASS = 255
"""Class id of an unknown cell: the ROS value -1 as an unsigned byte."""
TRANSPARENT = (0, 0, 0, 0)
"""RGBA of unknown cells."""
MERGED_FREE = (90, 150, 255, 80)
"""RGBA of the merged map's free cells: a tint that leaves the truth visible."""
MERGED_UNCERTAIN = (200, 0, 200, 60)
"""RGBA of the merged map's cells between free and occupied."""
MERGED_WALL = (200, 0, 200, 255)
"""RGBA of the merged map's occupied cells: magenta, a colour no robot has."""


def cell_label(value: int) -> str:
    """What a ROS cell value means: ``free``, ``occupied``, ``unknown`` or ``p % occupied``."""
    if value == UNKNOWN_CLASS:
        return "unknown"
    if value <= FREE_THRESHOLD:
        return f"free ({value} %)"
    if value >= OCCUPIED_THRESHOLD:
        return f"occupied ({value} %)"
    return f"{value} % occupied"


def map_classes() -> rr.AnnotationContext:
    """map_server greys for 0..100 (free white, occupied black), unknown transparent."""
    infos = [
        rr.AnnotationInfo(
            id=value,
            label=cell_label(value),
            color=(*(3 * (round(255 * (1 - value / OCCUPIED)),)), 255),
        )
        for value in range(OCCUPIED + 1)
    ]
    infos.append(rr.AnnotationInfo(id=UNKNOWN_CLASS, label="unknown", color=TRANSPARENT))
    return rr.AnnotationContext(infos)


def merged_classes() -> rr.AnnotationContext:
    """The merged map's colours (module docstring)."""
    infos = []
    for value in range(OCCUPIED + 1):
        if value <= FREE_THRESHOLD:
            colour = MERGED_FREE
        elif value >= OCCUPIED_THRESHOLD:
            colour = MERGED_WALL
        else:
            colour = MERGED_UNCERTAIN
        infos.append(
            rr.AnnotationInfo(id=value, label=f"merged: {cell_label(value)}", color=colour)
        )
    infos.append(rr.AnnotationInfo(id=UNKNOWN_CLASS, label="unknown", color=TRANSPARENT))
    return rr.AnnotationContext(infos)
