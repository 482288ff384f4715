"""Check N maps merged at once: every E5 session linked together, against the floor's truth.

``merging.merge_all`` estimates every pair of the Halmstad E5 floor's sessions,
drops pairs that contradict the others, links the rest and places each
session in one frame. For each of the 109 pairs with a known transform
(``halmstad/truth_E5.json``) this compares the transform the linking implies
between the two sessions with the truth, by the floor's rule (right within
``max(1.5 * rms, rms + 10)`` cells), beside the pairwise estimate alone
(right, and accepted). Writes ``linking.csv`` (a row per known pair) and
``linking.md``.

Usage::

    python scripts/bench_linking.py                    # all 14 sessions (about 10 s)
    python scripts/bench_linking.py --sessions E5_01 E5_02 E5_03 E5_12 E5_14
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

import merging
from merging.evaluation.metrics import transform_error
from tomosim.commands.script_args import run_script, shared_maps


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    parser.add_argument("--sessions", nargs="+", default=None,
                        help="E5 sessions to merge (default: all of them)")  # fmt: skip
    parser.add_argument("--out", type=Path, default=Path("results/bench_linking"))
    args = parser.parse_args(argv)
    folder = shared_maps()
    halmstad = folder / "halmstad"
    names = args.sessions or sorted(p.stem for p in halmstad.glob("E5_*.yaml"))
    missing = [name for name in names if not (halmstad / f"{name}.yaml").is_file()]
    if missing or len(names) < 2:
        print(f"error: give at least two E5 sessions of {halmstad}; not found: {missing}",
              file=sys.stderr)  # fmt: skip
        return 2
    truth = json.loads((halmstad / "truth_E5.json").read_text())["pairs"]
    if not any(set(key.split("|")) <= set(names) for key in truth):
        print(f"error: no two of the sessions {names} form a pair of truth_E5.json; give E5 "
              "sessions (e.g. E5_01 E5_02)", file=sys.stderr)  # fmt: skip
        return 2
    grids = [merging.load_map(halmstad / f"{name}.yaml") for name in names]
    clock = time.perf_counter()
    linking = merging.merge_all(grids, rng=0).linking
    seconds = time.perf_counter() - clock
    args.out.mkdir(parents=True, exist_ok=True)
    rows: list[dict[str, Any]] = []
    for key, entry in sorted(truth.items()):
        first, second = key.split("|")
        if first not in names or second not in names:
            continue
        i, j = names.index(first), names.index(second)
        known = np.array(entry["matrix_cells"])
        tolerance = max(1.5 * entry["rms_cells"], entry["rms_cells"] + 10)
        cells = grids[j].data
        pair = linking.pair(i, j)  # map j -> map i, whichever order
        pairwise = transform_error(pair.matrix, known, cells)[0]
        implied = linking.relative(i, j)
        through = np.nan if implied is None else transform_error(implied, known, cells)[0]
        rows.append({
            "pair": key, "tolerance": round(tolerance, 1),
            "pairwise_cells": round(pairwise, 1), "pairwise_accepted": pair.accepted,
            "linked_cells": round(float(through), 1),
        })  # fmt: skip
    with (args.out / "linking.csv").open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    right_pairwise = sum(r["pairwise_cells"] <= r["tolerance"] for r in rows)
    accepted_right = sum(r["pairwise_cells"] <= r["tolerance"] and r["pairwise_accepted"]
                         for r in rows)  # fmt: skip
    linked = [r for r in rows if np.isfinite(r["linked_cells"])]
    right_linked = sum(r["linked_cells"] <= r["tolerance"] for r in linked)
    wrong = [r for r in linked if r["linked_cells"] > r["tolerance"]]
    lines = [
        f"# {len(names)} E5 sessions merged at once", "",
        f"{len(rows)} pairs with a known transform; merge_all took {seconds:.1f} s.", "",
        "| | right | of |", "|---|---|---|",
        f"| pairwise estimate | {right_pairwise} | {len(rows)} |",
        f"| pairwise estimate, accepted | {accepted_right} | {len(rows)} |",
        f"| implied by the linking (sessions linked) | {right_linked} | {len(linked)} |",
        "", f"Dropped pairs: {len(linking.dropped)}; groups: "
        f"{[len(g) for g in linking.groups]}.",
    ]  # fmt: skip
    lines += [f"- off: {r['pair']} {r['linked_cells']} cells (tolerance {r['tolerance']})"
              for r in wrong]  # fmt: skip
    (args.out / "linking.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    run_script(main, __file__)
