"""The study's figures: time to the target against team size, speed-ups and the oracle's share."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from exploration_study.summary import (
    ORACLE,
    TOMOGRAPHIC,
    Cell,
    lookup,
    oracle_share,
    pooled,
    speedup,
)
from exploration_study.worlds import StudyWorld
from tomosim.sweep import NO_MERGE

Table = dict[tuple[int, str, str], Cell]

FIGURE_DPI = 80
"""Resolution of the PNGs: small files that still read on a screen."""
STYLES = {
    NO_MERGE: ("no merging", "tab:grey", "s"),
    TOMOGRAPHIC: ("tomographic merging", "tab:blue", "o"),
    ORACLE: ("known start poses (oracle)", "tab:green", "^"),
}
"""Label, colour and marker per method."""


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def times_figure(
    worlds: Sequence[StudyWorld],
    tables: dict[str, Table],
    policy: str,
    robots: Sequence[int],
    path: Path,
) -> None:
    """Per world: median time to 90 % against team size per method, min-max bars; an open
    marker at the cap where the median episode did not get there."""
    shown = [w for w in worlds if tables.get(w.label)]
    if not shown:
        return
    plt = _pyplot()
    figure, axes = plt.subplots(1, len(shown), figsize=(3.6 * len(shown), 3.4), squeeze=False)
    for axis, world in zip(axes[0], shown, strict=True):
        cap = world.steps * 0.1
        for k, (method, (label, colour, marker)) in enumerate(STYLES.items()):
            xs, ys, low, high, capped = [], [], [], [], []
            for n in robots:
                cell = lookup(tables[world.label], n, policy, method)
                if cell is None:
                    continue
                x = n + (k - 1) * 0.12
                lo, hi = (min(v, cap) for v in cell.spread)
                median = cell.median
                if math.isinf(median):
                    capped.append(x)
                    continue
                xs.append(x)
                ys.append(median)
                low.append(median - lo)
                high.append(hi - median)
            if xs:
                axis.errorbar(xs, ys, yerr=[low, high], color=colour, marker=marker, ms=5,
                              capsize=2, lw=1.2, label=label)  # fmt: skip
            if capped:
                axis.plot(capped, [cap] * len(capped), marker=marker, ls="none", mfc="none",
                          color=colour)  # fmt: skip
        axis.axhline(cap, color="black", lw=0.6, ls=":")
        axis.set_title(f"{world.label} (cap {cap:.0f} s)", fontsize=10)
        axis.set_xlabel("robots")
        axis.set_xticks(list(robots))
        axis.set_ylim(bottom=0)
        axis.grid(alpha=0.3)
    axes[0, 0].set_ylabel("simulated seconds to 90 % coverage")
    if axes[0, 0].get_legend_handles_labels()[0]:
        axes[0, 0].legend(fontsize=7)
    figure.tight_layout()
    figure.savefig(path, dpi=FIGURE_DPI)
    plt.close(figure)


def gains_figure(
    worlds: Sequence[StudyWorld],
    tables: dict[str, Table],
    policy: str,
    robots: Sequence[int],
    path: Path,
) -> None:
    """Left: speed-up of merging over none against team size (tomographic solid, oracle
    dashed) per world, and over the generated floors pooled (black). Right: the share of
    the oracle's speed-up the tomographic merger reaches."""
    teams = [n for n in robots if n > 1]
    shown = [w for w in worlds if tables.get(w.label)]
    if not shown or not teams:
        return
    floors = [tables[w.label] for w in shown if w.generated]
    series: list[tuple[str, dict[tuple[int, str], float]]] = []
    for world in shown:
        series.append((world.label, _medians(teams, policy, [tables[world.label]], pooled_=False)))
    if len(floors) > 1:
        series.append(("floors pooled", _medians(teams, policy, floors, pooled_=True)))
    plt = _pyplot()
    figure, (left, right) = plt.subplots(1, 2, figsize=(9.0, 3.4))
    colours = plt.get_cmap("tab10")
    width = 0.8 / len(series)
    for k, (label, medians) in enumerate(series):
        tomo = [speedup(medians[(n, NO_MERGE)], medians[(n, TOMOGRAPHIC)]) for n in teams]
        oracle = [speedup(medians[(n, NO_MERGE)], medians[(n, ORACLE)]) for n in teams]
        colour = "black" if label == "floors pooled" else colours(k)
        left.plot(teams, tomo, marker="o", color=colour, label=label)
        left.plot(teams, oracle, marker="^", ls="--", color=colour, alpha=0.7)
        share = [
            oracle_share(medians[(n, NO_MERGE)], medians[(n, TOMOGRAPHIC)], medians[(n, ORACLE)])
            for n in teams
        ]
        right.bar(np.arange(len(teams)) + k * width, np.nan_to_num(share, nan=0.0), width,
                  color=colour, label=label)  # fmt: skip
    left.axhline(1.0, color="black", lw=0.6)
    left.set_xticks(teams)
    left.set_xlabel("robots")
    left.set_ylabel("speed-up over no merging")
    left.set_title("tomographic (solid) and oracle (dashed)", fontsize=10)
    left.legend(fontsize=7)
    left.grid(alpha=0.3)
    right.axhline(1.0, color="black", lw=0.6)
    right.set_xticks(np.arange(len(teams)) + width * (len(series) - 1) / 2)
    right.set_xticklabels([f"{n} robots" for n in teams])
    right.set_ylabel("share of the oracle's speed-up")
    right.set_title("tomographic merging vs known start poses", fontsize=10)
    right.grid(axis="y", alpha=0.3)
    figure.tight_layout()
    figure.savefig(path, dpi=FIGURE_DPI)
    plt.close(figure)


def _medians(
    teams: Sequence[int], policy: str, tables: Sequence[Table], *, pooled_: bool
) -> dict[tuple[int, str], float]:
    """Median time per team size and method, of one world or of several pooled."""
    out = {}
    for n in teams:
        for method in STYLES:
            cell = (
                pooled(tables, n, policy, method)
                if pooled_
                else lookup(tables[0], n, policy, method)
            )
            out[(n, method)] = cell.median if cell is not None else math.nan
    return out
