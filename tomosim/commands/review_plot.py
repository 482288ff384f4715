"""The PNG ``tomosim review`` writes: final merged map beside the truth, errors, coverage.

Maps are drawn in the ROS map_server colours (occupied black, free white,
unknown grey) in the world frame (metres, ``y`` up): the merged map is placed
by its reference robot's true start pose, as recorded, so that any
misalignment with the truth beside it shows. Errors are drawn on logarithmic
axes (ticks at 1, 2 and 5 of each decade): a wrong merge is off by metres, a
right one by centimetres. Each pair is in the colour the viewer draws it in.
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from merging.grid import OccupancyGrid
from tomosim.commands import CommandError
from tomosim.commands.explore_report import settings_line
from tomosim.recording import RecordedRun
from tomosim.recording.paths import AGREEMENT, MERGED, MERGED_FRAME, TRUTH, pair_colour

UNKNOWN_GREY = 205 / 255
"""Grey of unknown cells: map_server's 205."""
FIGURE_SIZE = (13.0, 8.0)
"""Inches."""
DPI = 110
"""Dots per inch of the PNG."""


def grey_levels(grid: OccupancyGrid) -> NDArray[np.float64]:
    """Cell brightness in ``[0, 1]``: ``1 - p`` for known cells, :data:`UNKNOWN_GREY` else."""
    cells = grid.data.astype(np.float64)
    return np.where(cells < 0, UNKNOWN_GREY, 1.0 - cells / 100.0)


def _pair_colour(name: str) -> tuple[float, float, float] | None:
    """The colour the viewer draws pair ``name`` (``r0-r2``) in, as matplotlib takes it."""
    robots = re.fullmatch(r"r(\d+)-r(\d+)", name)
    if robots is None:
        return None
    red, green, blue = pair_colour(int(robots[1]), int(robots[2]))
    return (red / 255, green / 255, blue / 255)


def _draw_grid(
    axes: Any,
    grid: OccupancyGrid | None,
    title: str,
    *,
    placement: tuple[float, float, float] = (0.0, 0.0, 0.0),
    limits: tuple[float, float, float, float] | None = None,
) -> None:
    """Draw ``grid`` placed by ``placement`` (its frame's pose in the axes' frame)."""
    from matplotlib.transforms import Affine2D

    axes.set_title(title, fontsize=10)
    axes.set_facecolor(str(UNKNOWN_GREY))
    axes.set_xlabel("x [m]")
    axes.set_ylabel("y [m]")
    if grid is None:
        axes.text(0.5, 0.5, "not recorded", ha="center", va="center", transform=axes.transAxes)
        return
    rows, cols = grid.shape
    ox, oy, yaw = grid.origin
    x, y, turn = placement
    place = Affine2D().rotate(yaw).translate(ox, oy).rotate(turn).translate(x, y)
    image = axes.imshow(
        grey_levels(grid),
        cmap="gray",
        vmin=0,
        vmax=1,
        origin="lower",
        extent=(0.0, cols * grid.resolution, 0.0, rows * grid.resolution),
        interpolation="nearest",
    )
    image.set_transform(place + axes.transData)
    if limits is None:
        corners = place.transform(
            np.array([[0, 0], [cols, 0], [0, rows], [cols, rows]], float) * grid.resolution
        )
        limits = (*corners.min(axis=0), *corners.max(axis=0))
    axes.set_xlim(limits[0], limits[2])
    axes.set_ylim(limits[1], limits[3])
    axes.set_aspect("equal")


def plot_summary(run: RecordedRun, report: dict[str, Any], path: Path) -> None:
    """Write the summary figure of ``run`` to ``path`` (PNG)."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter
    except ImportError as exc:
        raise CommandError(
            "the summary image needs matplotlib: python -m pip install matplotlib "
            "(or pass --no-png)"
        ) from exc
    figure, axes = plt.subplot_mosaic(
        [
            ["truth", "truth", "truth", "merged", "merged", "merged"],
            ["rot", "rot", "shift", "shift", "cov", "cov"],
        ],
        figsize=FIGURE_SIZE,
        height_ratios=[1.6, 1.0],
        layout="constrained",
    )
    truth = run.grids.get(TRUTH)
    merged = run.grids.get(MERGED)
    limits = None
    if truth is not None:
        rows, cols = truth[1].shape
        ox, oy, _ = truth[1].origin
        res = truth[1].resolution
        limits = (ox, oy, ox + cols * res, oy + rows * res)
    _draw_grid(axes["truth"], None if truth is None else truth[1], "ground truth", limits=limits)
    _draw_grid(
        axes["merged"],
        None if merged is None else merged[1],
        "merged map" if merged is None else f"merged map at step {merged[0]}, placed by truth",
        placement=run.poses.get(MERGED_FRAME, (0.0, 0.0, 0.0)),
        limits=limits,
    )
    for key, quantity, label in (
        ("rot", "rotation_error_deg", "rotation error [deg]"),
        ("shift", "translation_error_m", "translation error [m]"),
    ):
        ax = axes[key]
        drawn = 0
        for name in run.pairs:
            series = run.pair(name, quantity)
            keep = np.isfinite(series.values) & (series.values > 0)
            if np.any(keep):
                colour = _pair_colour(name)
                ax.plot(series.steps[keep], series.values[keep], marker="o", ms=3, label=name,
                        color=colour)  # fmt: skip
                drawn += 1
        ax.set_title(f"accepted merges: {label}", fontsize=10)
        ax.set_xlabel("step")
        if drawn:
            ax.set_yscale("log")
            # Ticks at 1, 2 and 5 of each decade, written 0.05, not 5 x 10^-2.
            ax.yaxis.set_major_locator(LogLocator(base=10.0, subs=(1.0, 2.0, 5.0)))
            ax.yaxis.set_major_formatter(FuncFormatter(lambda value, _: f"{value:g}"))
            ax.yaxis.set_minor_formatter(NullFormatter())
            ax.legend(fontsize=8)
        else:
            ax.text(0.5, 0.5, "no accepted merge", ha="center", va="center", transform=ax.transAxes)
        ax.grid(alpha=0.3)
    ax = axes["cov"]
    coverage = run.coverage
    # Greys, as the pairs' colours (the viewer's) mean pairs in the charts beside.
    ax.plot(coverage.steps, coverage.values, color="0.45", label="team coverage")
    agreement = run.series.get(AGREEMENT)
    if agreement is not None and len(agreement.steps):
        ax.plot(agreement.steps, agreement.values, marker="o", ms=3, color="black",
                label="merged-map agreement")  # fmt: skip
    target = run.settings.get("coverage_target")
    if isinstance(target, float) and math.isfinite(target):
        ax.axhline(target, color="grey", ls="--", lw=0.8, label=f"coverage target {target:g}")
    for key, label, style in (
        ("first_link_step", "first link", ":"),
        ("all_linked_step", "all linked", "-."),
    ):
        step = report.get(key)
        if step is not None:
            ax.axvline(step, color="0.3", ls=style, lw=0.9, label=f"{label}, step {step}")
    ax.set_ylim(0, 1.02)
    ax.set_xlabel("step")
    ax.set_title("coverage and agreement with the truth", fontsize=10)
    ax.legend(fontsize=8, loc="lower right")
    ax.grid(alpha=0.3)
    s = report.get("settings") or {}
    if s:
        coverage = report["coverage"]
        figure.suptitle(
            f"{settings_line(s)}; final coverage "
            f"{'-' if coverage is None else f'{coverage:.3f}'} after {report['steps']} steps",
            fontsize=11,
        )
    if not report.get("finished", True):
        # A figure-level label, so that the constrained layout keeps room for it below
        # the axes' own labels.
        figure.supxlabel(f"run {report['status']}", x=0.01, ha="left", color="darkred", fontsize=9)
    partial = path.with_name(path.name + ".partial")
    try:
        figure.savefig(partial, dpi=DPI, format="png")
        partial.replace(path)  # whole or not at all
    finally:
        plt.close(figure)
        partial.unlink(missing_ok=True)
