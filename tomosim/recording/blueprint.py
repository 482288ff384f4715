"""The layout the viewer opens a tomosim recording with.

Left, the world seen from above (a 2-D view, ``y`` up): the ground truth, the
robots with their scans and paths, and the merged map laid over the truth,
placed by its reference robot's true start pose, its walls in their own colour
so that a misplaced wall stands out. Right, in tabs, the merged map alone
(placed the same way) and each robot's own map in its own frame (2-D views);
below them the charts: the rotation and translation errors of accepted
estimates against the truth, per pair; each pair's confidence with the merged
map's agreement with the truth; the team's exploration, every scalar
series under ``team/`` but the path lengths (coverage, each robot's own
coverage, the overlap rate, and any metric logged there later shows without a
change here); and the path lengths in metres, apart, as their scale dwarfs
the fractions. The charts stand two to a row, an odd last one alone across
the column. The time cursor follows the latest step, so a
finished recording opens on its last state and a live one keeps up; the side
panels start collapsed.

Every filter names a path of :mod:`tomosim.recording.paths` or a subtree of it
with a trailing ``/**`` (rerun's filters know no other wildcard).
"""

from __future__ import annotations

from collections.abc import Sequence

import rerun.blueprint as rrb

from tomosim.recording.paths import (
    AGREEMENT,
    MERGED_FRAME,
    PATH_LENGTHS,
    STEP_TIMELINE,
    TEAM,
    WORLD,
    map_frame_path,
    quantity_path,
)
from tomosim.team.merger import robot_name

BACKGROUND = (205, 205, 205)
"""RGB behind the maps: map_server's grey for unknown cells, which are drawn
transparent, so that the unknown parts of a map read as in any ROS map viewer."""
MARGIN_FRACTION = 0.03
"""Blank border around the world in the world view, as a fraction of its larger side."""
WORLD_SHARE, SIDE_SHARE = 3, 2
"""Widths of the world view and of the maps-and-charts column."""
MAPS_SHARE, CHARTS_SHARE = 1, 2
"""Heights of the map tabs and of the charts in the right column (the merged map is
in the world view too; the charts need the height to show their values and legends)."""


def world_view(
    bounds: tuple[float, float, float, float], *, name: str = "World: truth, robots, merged map"
) -> rrb.Spatial2DView:
    """The world from above, framed on ``bounds = (xmin, ymin, xmax, ymax)`` in metres."""
    xmin, ymin, xmax, ymax = bounds
    margin = MARGIN_FRACTION * max(xmax - xmin, ymax - ymin, 1.0)
    # The view's frame is the world's mirrored in y (see paths.WORLD).
    framing = rrb.VisualBounds2D(
        x_range=[xmin - margin, xmax + margin], y_range=[-ymax - margin, -ymin + margin]
    )
    return rrb.Spatial2DView(
        name=name,
        origin="/",
        contents=[f"+ {WORLD}/**"],
        background=BACKGROUND,
        visual_bounds=framing,
    )


def map_views(robots: int, *, merging: bool) -> list[rrb.Spatial2DView]:
    """The merged map (placed in the world by truth) and each robot's own map."""
    views = []
    if merging:
        views.append(
            rrb.Spatial2DView(
                name="Merged map (placed by truth)",
                origin="/",
                contents=[f"+ {MERGED_FRAME}/**"],
                background=BACKGROUND,
            )
        )
    for k in range(robots):
        views.append(
            rrb.Spatial2DView(
                name=f"Map {robot_name(k)}",
                origin="/",
                contents=[f"+ {map_frame_path(k)}/**"],
                background=BACKGROUND,
            )
        )
    return views


def chart_views(*, merging: bool) -> list[rrb.TimeSeriesView]:
    """Merge errors, confidence and agreement (when merging) and the team's series."""
    charts = []
    if merging:
        charts += [
            rrb.TimeSeriesView(
                name="Rotation error [deg]",
                origin="/",
                contents=[f"+ {quantity_path('rotation_error_deg')}/**"],
                # Errors fall from where the first estimates start: the lower left, before
                # them, stays clear; on the right a late pair's first estimates arrive.
                plot_legend=rrb.PlotLegend(corner=rrb.Corner2D.LeftBottom),
            ),
            rrb.TimeSeriesView(
                name="Translation error [m]",
                origin="/",
                contents=[f"+ {quantity_path('translation_error_m')}/**"],
                plot_legend=rrb.PlotLegend(corner=rrb.Corner2D.LeftBottom),
            ),
            rrb.TimeSeriesView(
                name="Confidence, agreement",
                origin="/",
                contents=[f"+ {quantity_path('confidence')}/**", f"+ {AGREEMENT}"],
            ),
            rrb.TimeSeriesView(
                name="Shared free space [m²]",
                origin="/",
                contents=[f"+ {quantity_path('shared_free_m2')}/**"],
                # Overlap grows from nothing: the upper left stays clear.
                plot_legend=rrb.PlotLegend(corner=rrb.Corner2D.LeftTop),
            ),
        ]
    charts += [
        rrb.TimeSeriesView(
            name="Coverage, overlap rate (fractions)",
            origin="/",
            contents=[f"+ {TEAM}/**", f"- {PATH_LENGTHS}/**"],
        ),
        rrb.TimeSeriesView(
            name="Path length [m]",
            origin="/",
            contents=[f"+ {PATH_LENGTHS}/**"],
            plot_legend=rrb.PlotLegend(corner=rrb.Corner2D.LeftTop),  # lengths grow
        ),
    ]
    return charts


def _column(views: Sequence[rrb.View]) -> rrb.Container:
    """Rows of two views side by side; an odd last view takes a row of its own."""
    rows: list[rrb.Container | rrb.View] = [
        rrb.Horizontal(*views[k : k + 2]) if k + 1 < len(views) else views[k]
        for k in range(0, len(views), 2)
    ]
    return rrb.Vertical(*rows)


def default_blueprint(
    robots: int, bounds: tuple[float, float, float, float], *, merging: bool = True
) -> rrb.Blueprint:
    """The default blueprint for ``robots`` robots in a world of ``(xmin, ymin, xmax, ymax)``.

    Parameters
    ----------
    robots : int
        Number of robots (one map tab each).
    bounds : (xmin, ymin, xmax, ymax)
        The world's extent in metres: the world view's initial framing.
    merging : bool
        Whether the run merges maps; without merging there is no merged map
        and no merge chart.
    """
    if robots < 1:
        raise ValueError(f"robots must be at least 1, got {robots}")
    side = rrb.Vertical(
        rrb.Tabs(*map_views(robots, merging=merging)),
        _column(chart_views(merging=merging)),
        row_shares=[MAPS_SHARE, CHARTS_SHARE],
    )
    return rrb.Blueprint(
        rrb.Horizontal(
            world_view(bounds) if merging else world_view(bounds, name="World: truth, robots"),
            side,
            column_shares=[WORLD_SHARE, SIDE_SHARE],
        ),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(state="collapsed", timeline=STEP_TIMELINE, play_state="following"),
    )
