"""The layout the viewer opens a tomosim recording with.

Left, the world seen from above: ground truth, walls, the robots with their
scans and paths, and the merged map laid over the truth (placed by its
reference robot's true start pose, so misplaced walls show). Right, one tab
per robot's own map and one for the merged map, and below them the merge
errors of accepted estimates and the team coverage against the step.
"""

from __future__ import annotations

import rerun.blueprint as rrb

from tomosim.recording.paths import AGREEMENT, COVERAGE, MERGED, map_path
from tomosim.team.merger import robot_name

EYE_HEIGHT_FACTOR = 1.2
"""Height of the initial top-down eye above the world, in multiples of the world's
larger side: the whole floor fits the default field of view."""


def default_blueprint(robots: int, bounds: tuple[float, float, float, float]) -> rrb.Blueprint:
    """The default blueprint for ``robots`` robots in a world of ``(xmin, ymin, xmax, ymax)``."""
    if robots < 1:
        raise ValueError(f"robots must be at least 1, got {robots}")
    xmin, ymin, xmax, ymax = bounds
    centre = ((xmin + xmax) / 2, (ymin + ymax) / 2)
    height = EYE_HEIGHT_FACTOR * max(xmax - xmin, ymax - ymin, 1.0)
    world = rrb.Spatial3DView(
        name="World: truth, robots, merged map",
        origin="/",
        contents=["+ world/**", f"+ {MERGED}"],
        eye_controls=rrb.EyeControls3D(
            position=(centre[0], centre[1], height),
            look_target=(centre[0], centre[1], 0.0),
            eye_up=(0.0, 1.0, 0.0),
        ),
        line_grid=False,
    )
    maps = rrb.Tabs(
        rrb.Spatial3DView(name="Merged map", origin=MERGED),
        *(
            rrb.Spatial3DView(name=f"Map {robot_name(k)}", origin=map_path(k))
            for k in range(robots)
        ),
    )
    charts = rrb.Vertical(
        rrb.TimeSeriesView(
            name="Rotation error of accepted merges [deg]",
            origin="merge",
            contents="+ merge/*/rotation_error_deg",
        ),
        rrb.TimeSeriesView(
            name="Translation error of accepted merges [m]",
            origin="merge",
            contents="+ merge/*/translation_error_m",
        ),
        rrb.TimeSeriesView(
            name="Team coverage and merged-map agreement",
            origin="/",
            contents=[f"+ {COVERAGE}", f"+ {AGREEMENT}"],
        ),
    )
    return rrb.Blueprint(
        rrb.Horizontal(world, rrb.Vertical(maps, charts, row_shares=[1, 1]), column_shares=[3, 2]),
        collapse_panels=False,
    )
