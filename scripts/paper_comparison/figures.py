"""Draw the report's figures: Figures 7-8 per row, the sinogram figures, the reference overlays.

Figures 3-5 are drawn by :mod:`paper_comparison.sinogram_figures`. matplotlib
is imported only when a figure is drawn, through
:func:`paper_comparison.plotting.pyplot`, which stops with
``pip install "tomosim[plot]"`` when it is missing.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from merging.grid import occupied_mask
from merging.warp import warp_cells

from .contenders import Contender
from .plotting import pyplot, save
from .sinogram_figures import plot_partial_sinograms, plot_sinograms
from .study import Case, Study
from .summary import table_rows

DOCS_FIGURES = (
    "sim_matching.png",
    "exp1_matching.png",
    "sinograms.png",
    "partial_sinograms.png",
)
"""The figures copied beside the report in the documentation folder: plots only.
The reference overlays draw the shared maps themselves, which the project does
not redistribute; they stay in the output folder."""
MARKERS = "os^vD<>xP*"
"""Marker of each method's points, in column order (repeated past ten methods)."""
KNOWN_GREY = 0.9
"""Grey level of the cells map 1 observed, in the reference overlays (unknown is white)."""
MAP1_WALLS = (0.9, 0.1, 0.1)
"""Colour (RGB) of map 1's walls alone in the reference overlays."""
MAP2_WALLS = (0.1, 0.2, 0.9)
"""Colour (RGB) of map 2's walls alone in the reference overlays; walls of both are black."""
OVERLAY_COLUMNS = 4
"""Overlays per line of the reference figure."""


def draw_figures(
    study: Study,
    contenders: Sequence[Contender],
    first_sim: Case | None,
    halmstad: Sequence[Case],
    out: Path,
) -> dict[str, str]:
    """Draw every figure into ``out``; returns file name -> caption."""
    figures: dict[str, str] = {}
    rows = table_rows(study)
    sim_rows = [row for row in rows if row.startswith("Sim.")]
    exp_rows = [row for row in rows if row.startswith("Exp.")]
    if sim_rows:
        plot_overlap_and_matching(
            study,
            contenders,
            sim_rows[0],
            out / "sim_matching.png",
            title=f"{sim_rows[0]}: overlap (Fig. 7) and matching index per pair (Fig. 8)",
        )
        figures["sim_matching.png"] = (
            f"{sim_rows[0]}: the overlap ratio of each pair (top, as in Figure 7) and each "
            "method's matching index (bottom, as in Figure 8), pairs sorted by overlap."
        )
    for index, row in enumerate(exp_rows, start=1):
        name = f"exp{index}_matching.png"
        plot_overlap_and_matching(
            study,
            contenders,
            row,
            out / name,
            title=f"{row}: overlap and matching index per pair (Figs. 12-13)",
        )
        figures[name] = f"{row}: overlap ratio and matching index per pair, sorted by overlap."
    if first_sim is not None:
        plot_sinograms(first_sim, out / "sinograms.png")
        figures["sinograms.png"] = (
            f"The sinograms of pair {first_sim.label} with their maxima marked (Figure 3); "
            "eq. (7) takes the rotation from the difference of the maxima's angles."
        )
        plot_partial_sinograms(first_sim, out / "partial_sinograms.png")
        figures["partial_sinograms.png"] = (
            f"Partial sinograms of pair {first_sim.label} at α' = 180° (x) and 90° (y) and "
            "their cross-correlations (Figures 4 and 5): red the argmax of eqs. (16)-(17), "
            "green dashed the shift the truth implies for the estimated rotation."
        )
    judged = [case for case in halmstad if case.label in study.references]
    if judged:
        plot_references(judged, study.references, out / "halmstad_references.png")
        figures["halmstad_references.png"] = (
            "The halmstad reference transforms of the judged pairs, to be checked by eye: "
            "map 1's walls red, map 2's blue, both black."
        )
    return figures


def plot_overlap_and_matching(
    study: Study, contenders: Sequence[Contender], row: str, path: Path, *, title: str
) -> None:
    """Figures 7 and 8 (12 and 13) of the paper: overlap ratio and per-pair Ψ, sorted by overlap."""
    rows = [r for r in study.rows if r.row == row and r.judged]
    cases = sorted({r.case: r.overlap for r in rows}.items(), key=lambda item: item[1])
    order = {case: k for k, (case, _) in enumerate(cases)}
    figure, (top, bottom) = pyplot().subplots(
        2, 1, figsize=(9, 7.5), sharex=True, gridspec_kw={"height_ratios": [1, 2]}
    )
    top.plot(range(len(cases)), [o for _, o in cases], "b:", marker=".", label="overlap ratio")
    top.set_ylabel("average overlap ratio")
    top.set_title(title)
    top.grid(alpha=0.3)
    for n, c in enumerate(contenders):
        mine = sorted((order[r.case], r.matching_index) for r in rows if r.method == c.key)
        xs, ys = zip(*mine, strict=True)
        bottom.plot(
            xs,
            ys,
            linestyle="none",
            marker=MARKERS[n % len(MARKERS)],
            markersize=4,
            label=c.label,
            alpha=0.8,
        )
    truth = sorted({(order[r.case], r.truth_matching_index) for r in rows})
    bottom.plot(*zip(*truth, strict=True), "k-", linewidth=1, label="truth (ceiling)")
    bottom.set_xlabel("pair, sorted by overlap ratio")
    bottom.set_ylabel("matching index Ψ (eq. 31)")
    bottom.set_ylim(-0.02, 1.02)
    bottom.grid(alpha=0.3)
    bottom.legend(fontsize=7, ncol=5, loc="upper center", bbox_to_anchor=(0.5, -0.14))
    save(figure, path)


def plot_references(
    cases: Sequence[Case], references: dict[str, NDArray[np.float64]], path: Path
) -> None:
    """Overlays of each reference (map 1 red, map 2 blue, both black), for checking by eye.

    ``references`` maps case labels to the matrix taking map 2's cells to map 1's.
    """
    count = len(cases)
    columns = min(count, OVERLAY_COLUMNS)
    lines = -(-count // columns)
    figure, axes = pyplot().subplots(
        lines, columns, figsize=(4 * columns, 3 * lines), squeeze=False
    )
    for axis in axes.ravel():
        axis.axis("off")
    for axis, case in zip(axes.ravel(), cases, strict=False):
        warped = warp_cells(case.map2, references[case.label], case.map1.shape)
        image = np.ones((*case.map1.shape, 3))
        image[case.map1 >= 0] = KNOWN_GREY
        walls1, walls2 = occupied_mask(case.map1), occupied_mask(warped)
        image[walls1] = MAP1_WALLS
        image[walls2] = MAP2_WALLS
        image[walls1 & walls2] = 0.0
        axis.imshow(image, origin="lower", interpolation="nearest")
        axis.set_title(case.label, fontsize=8)
    save(figure, path)
