"""The learning curve's plot: team coverage and return against timesteps, baselines as lines."""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Any

import numpy as np

CURVE_WINDOW = 20
"""Points (training episodes or iterations) in the rolling mean of the plot."""
CURVE_COLUMNS = ("timesteps", "mean_return", "team_coverage")
"""The columns of a learning-curve CSV the plot reads (a file may have more)."""


def plot_curve(
    csv_path: Path, png_path: Path, summary: dict[str, Any], *, title: str, points: str
) -> None:
    """Rolling mean of team coverage and return against timesteps, with the held-out
    figures of :mod:`policy_comparison.evaluation` as dashed lines.

    Parameters
    ----------
    csv_path : Path
        A learning curve with the columns :data:`CURVE_COLUMNS`, one row per point.
    png_path : Path
        Where the figure goes.
    summary : dict
        The run's summary, with its ``evaluation``.
    title : str
        The figure's title.
    points : str
        What a row of the CSV is, for the legend ("training episodes").
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    with csv_path.open() as handle:
        rows = list(csv.DictReader(handle))
    steps = np.array([float(r["timesteps"]) for r in rows])
    figure, axes = plt.subplots(1, 2, figsize=(11, 4))
    for axis, key, label in (
        (axes[0], "team_coverage", "final team coverage"),
        (axes[1], "mean_return", "episode return per robot [m²]"),
    ):
        values = np.array([float(r[key]) for r in rows])
        if len(values):
            window = min(CURVE_WINDOW, len(values))
            smooth = np.convolve(values, np.ones(window) / window, mode="valid")
            axis.plot(steps, values, ".", alpha=0.25, color="tab:blue", label=points)
            axis.plot(
                steps[len(steps) - len(smooth) :], smooth, color="tab:blue", label="rolling mean"
            )
        for name, colour in (
            ("trained", "tab:blue"),
            ("best_constant", "tab:orange"),
            ("random", "tab:grey"),
            ("frontier", "tab:green"),
        ):
            axis.axhline(
                summary["evaluation"][name][key],
                color=colour,
                linestyle="--",
                label=f"{name.replace('_', ' ')} (held-out)",
            )
        axis.set_xlabel("agent-steps (timesteps)")
        axis.set_ylabel(label)
        axis.grid(alpha=0.3)
    axes[0].legend(fontsize=8, loc="lower right")
    figure.suptitle(title)
    figure.tight_layout()
    figure.savefig(png_path, dpi=110)
    plt.close(figure)
