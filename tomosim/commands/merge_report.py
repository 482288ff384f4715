"""What ``tomosim merge`` prints: a JSON-ready summary of a merge and its table rendering.

Transforms are reported as ``(x, y, theta)``: the translation and the
counter-clockwise rotation (degrees) of a rigid matrix, in cells for the
matrices between cell frames and in metres for those between map frames.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from merging import MergeAllResult, OccupancyGrid, cells_to_metres, matrix_to_pose
from merging.evaluation.metrics import transform_error


def fixed(value: float, digits: int) -> str:
    """``value`` with ``digits`` decimals, never printing ``-0.0``."""
    return f"{round(value, digits) + 0.0:.{digits}f}"


def pose(matrix: NDArray[np.float64]) -> dict[str, float]:
    """``{"x", "y", "theta_deg"}`` of a rigid 3x3 matrix."""
    x, y, theta = matrix_to_pose(matrix)
    return {"x": x, "y": y, "theta_deg": float(np.degrees(theta))}


def summarise(
    result: MergeAllResult,
    grids: Sequence[OccupancyGrid],
    paths: Sequence[Path],
    output: Path,
    *,
    truth: NDArray[np.float64] | None = None,
) -> dict[str, Any]:
    """A JSON-serialisable account of a merge.

    Per map: the transform from its cells into the fused map's cells and from
    its frame into the fused map's frame in metres (the reference map's frame).
    Per pair ``i < j``: the estimate taking map ``j``'s cells to map ``i``'s.
    With ``truth`` (map 1 cells -> map 0 cells), the demo's true transform and
    the estimate's error against it.
    """
    fused = result.fused.grid
    if fused is None:
        raise ValueError("the merge result has no georeferenced fused grid to report on")
    maps = []
    # The reference is linked only when some other map is linked to it.
    any_link = len(result.unlinked) < len(grids) - 1
    for k, (grid, path) in enumerate(zip(grids, paths, strict=True)):
        into = result.fused_transform(k)
        linked = into is not None and any_link
        entry: dict[str, Any] = {"index": k, "path": str(path), "linked": linked}
        if into is not None:
            entry["cells"] = pose(into)
            entry["metres"] = pose(cells_to_metres(into, fused, grid))
            entry["matrix"] = into.tolist()
        maps.append(entry)
    pairs = [
        {
            "i": i,
            "j": j,
            "confidence": float(pair.confidence),
            "accepted": bool(pair.accepted),
            "in_tree": (i, j) in result.tree,
            "cells": pose(pair.matrix),
            "reason": pair.reason,
        }
        for (i, j), pair in sorted(result.pairs.items())
    ]
    summary: dict[str, Any] = {
        "output": str(output),
        "reference": {"index": result.reference, "path": str(paths[result.reference])},
        "fused": {
            "rows": fused.shape[0],
            "cols": fused.shape[1],
            "resolution": fused.resolution,
            "origin": list(fused.origin),
        },
        "maps": maps,
        "pairs": pairs,
        "unlinked": list(result.unlinked),
        "notes": list(result.notes),
    }
    if truth is not None:
        estimate = result.pair(0, 1)
        rms, rotation = transform_error(estimate.matrix, truth, grids[1].data)
        summary["demo"] = {
            "truth": pose(truth),
            "estimate": pose(estimate.matrix),
            "accepted": bool(estimate.accepted),
            "confidence": float(estimate.confidence),
            "error_rms_cells": rms,
            "error_rotation_deg": rotation,
        }
    return summary


def format_table(
    headers: Sequence[str], rows: Sequence[Sequence[str]], *, left: Sequence[int] = (0,)
) -> str:
    """Columns padded to a common width; columns numbered in ``left`` left-aligned, others right."""
    widths = [max(len(str(row[c])) for row in [headers, *rows]) for c in range(len(headers))]
    lines = []
    for row in [headers, *rows]:
        cells = [
            str(value).ljust(width) if c in left else str(value).rjust(width)
            for c, (value, width) in enumerate(zip(row, widths, strict=True))
        ]
        lines.append("  ".join(cells).rstrip())
    return "\n".join(lines)


def render_table(summary: dict[str, Any]) -> str:
    """The human-readable report of :func:`summarise`'s summary."""
    fused, reference = summary["fused"], summary["reference"]
    written = "" if summary.get("written", True) else " (not written)"
    lines = [
        f"merged map{written}: {summary['output']} ({fused['rows']} x {fused['cols']} cells at "
        f"{fused['resolution']:g} m), reference map {reference['index']} ({reference['path']})",
        "",
        "each map in the merged map: its cells -> merged grid cells (x, y, theta) and",
        "its frame -> merged map frame in metres (x, y, yaw)",
    ]
    rows = []
    for entry in summary["maps"]:
        if entry["linked"]:
            c, m = entry["cells"], entry["metres"]
            cells = [fixed(c["x"], 1), fixed(c["y"], 1), fixed(c["theta_deg"], 2)]
            metres = [fixed(m["x"], 3), fixed(m["y"], 3), fixed(m["theta_deg"], 2)]
            rows.append([str(entry["index"]), entry["path"], "yes", *cells, *metres])
        else:
            rows.append([str(entry["index"]), entry["path"], "no", *["-"] * 6])
    headers = ["map", "file", "linked", "x [cells]", "y [cells]", "theta [deg]"]
    headers += ["x [m]", "y [m]", "yaw [deg]"]
    lines += [format_table(headers, rows, left=(0, 1)), ""]
    lines.append("pairwise estimates (map j -> map i, cells)")
    rows = [
        [
            f"{p['i']}-{p['j']}",
            f"{p['confidence']:.3f}",
            "yes" if p["accepted"] else "no",
            "yes" if p["in_tree"] else "no",
            fixed(p["cells"]["x"], 1),
            fixed(p["cells"]["y"], 1),
            fixed(p["cells"]["theta_deg"], 2),
            p["reason"],
        ]
        for p in summary["pairs"]
    ]
    headers = ["pair", "confidence", "accepted", "used", "x", "y", "theta [deg]", "reason"]
    lines.append(format_table(headers, rows, left=(0, 7)))
    if summary.get("merger_settings"):
        changed = ", ".join(f"{name}={value}" for name, value in summary["merger_settings"].items())
        lines.append(f"merger settings changed: {changed}")
    if "demo" in summary:
        demo = summary["demo"]
        t, e = demo["truth"], demo["estimate"]
        verdict = "accepted" if demo["accepted"] else "not accepted"
        lines += [
            "",
            "demo: map 1 -> map 0      x [cells]  y [cells]  theta [deg]",
            f"  true                {t['x']:11.1f}{t['y']:11.1f}{t['theta_deg']:13.2f}",
            f"  estimated           {e['x']:11.1f}{e['y']:11.1f}{e['theta_deg']:13.2f}"
            f"   ({verdict}, confidence {demo['confidence']:.3f})",
            f"  error: {demo['error_rms_cells']:.2f} cells RMS over map 1's walls, "
            f"{demo['error_rotation_deg']:.2f} deg",
        ]
    if summary["notes"]:
        lines += ["", "notes:", *(f"  {note}" for note in summary["notes"])]
    return "\n".join(lines)
