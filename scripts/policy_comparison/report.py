"""A finished training run's outputs: ``summary.json``, the learning-curve plot, the printout."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from .curves import plot_curve
from .evaluation import print_comparison


def write_run_outputs(
    out: Path, summary: dict[str, Any], curve_csv: Path, *, title: str, points: str
) -> None:
    """Write ``summary.json`` and ``learning_curve.png`` into ``out`` and print the comparison.

    Parameters
    ----------
    out : Path
        The run's output folder (it exists).
    summary : dict
        The run's summary, with ``timesteps``, ``training_seconds`` and the
        ``evaluation`` of :func:`policy_comparison.evaluation.compare`.
    curve_csv : Path
        The learning curve the run wrote (see :func:`policy_comparison.curves.plot_curve`).
    title, points : str
        The plot's title and what a row of the curve is.
    """
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    plot_curve(curve_csv, out / "learning_curve.png", summary, title=title, points=points)
    print(
        f"trained {summary['timesteps']} agent-steps in {summary['training_seconds']:.0f} s; "
        "held-out floors:"
    )
    print_comparison(summary)
    print(f"outputs in {out}")
