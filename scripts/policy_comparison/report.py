"""A training run's output folder: refused when already used; ``summary.json``, the
learning-curve plot and the printout written when the run is done."""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from .curves import plot_curve
from .evaluation import print_comparison


def refuse_used_folder(parser: argparse.ArgumentParser, out: Path, outputs: Sequence[str]) -> None:
    """Stop with a usage error when ``out`` already holds any of a run's ``outputs``: a
    rerun, or one interrupted, would leave old and new files mixed."""
    written = [name for name in outputs if (out / name).exists()]
    if written:
        parser.error(
            f"--out {out} already holds a run ({', '.join(written)}); choose another "
            "folder or remove it"
        )


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
