"""Check the mergers on floors without a known truth, by consistency around cycles of three.

The Halmstad data set maps four floors in several sessions each; only the E5
floor's pairs have a known transform (``bench_real_maps.py sessions``). On the
other floors (F5: 14 sessions, HIH and KPT4A: 4 each) every pair of sessions
is merged, and every three sessions whose three pairs are all accepted form a
cycle: the transform from C to A must be that from B to A after that from C
to B. How far the two put C's walls apart (cells RMS) is the cycle's error.

A cycle of right answers closes only up to the sessions' own bending (each
right answer may be 10-35 cells off the annotated fit on E5), so a cycle
error of a few tens of cells is what bent maps give; one of hundreds of cells
means an accepted answer is wrong. The report counts both, names the cycles
above ``--look-cells``, and ``--overlays`` draws each accepted pair of those
(map 1's walls black, map 2's placed by the answer red, on map 1's open
space in grey) to look at.

Every pair's answer is appended to ``pairs.csv`` as soon as it is known; the
report is ``cycles.md``.

Usage::

    python scripts/bench_cycles.py                            # F5, HIH, KPT4A; the default
    python scripts/bench_cycles.py --floors HIH --methods tomographic ros_akaze
    python scripts/bench_cycles.py --floors F5 --merger robust.margin=0.2

The report also holds each refused pair against the chains of two accepted
answers around it: a refused answer that agrees with them was right but not
vouched for, one hundreds of cells from them wrong. And it links each floor's
sessions from every method's pairwise answers at once (:func:`merging.link_maps`,
what :func:`merging.merge_all` does), which places the pairs a method refused
through the others: how many sessions end in one group, and how far each
pairwise answer, accepted or refused, lies from the transform the linking gives.

``--merger NAME=VALUE`` (repeatable) changes a setting of the default method by its dotted name
(:mod:`merging.settings`); the report names the settings changed.
"""

from __future__ import annotations

import argparse
import csv
import itertools
import json
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

import merging
from merging.api import DEFAULT_METHOD
from merging.evaluation.metrics import transform_error
from merging.params import TomographicParams
from merging.result import MergeResult
from tomosim.commands.merger_options import add_merger_argument, changed, merger_params
from tomosim.commands.script_args import positive_float, run_script, shared_maps

FLOORS = ("F5", "HIH", "KPT4A")
"""The Halmstad floors without a known transform between their sessions."""
WRONG_CELLS = 100.0
"""A cycle missing by more than this (5 m at 0.05 m) holds a wrong accepted answer:
far beyond what sessions bend by."""


@dataclass(frozen=True)
class Answer:
    """One method's answer for one pair of sessions (map 2 = ``second`` onto ``first``)."""

    floor: str
    first: str
    second: str
    method: str
    seconds: float
    result: MergeResult

    @property
    def accepted(self) -> bool:
        return bool(self.result.accepted)

    @property
    def matrix(self) -> NDArray[np.float64]:
        return self.result.matrix

    @property
    def reason(self) -> str:
        return self.result.reason


def sessions(folder: Path, floor: str) -> list[str]:
    """The names of ``floor``'s sessions in ``folder``, in order."""
    return sorted(path.stem for path in folder.glob(f"{floor}_*.yaml"))


def merge_floor(
    folder: Path,
    floor: str,
    methods: list[str],
    writer: csv.DictWriter,
    handle,
    params: TomographicParams | None = None,
) -> list[Answer]:
    """Every method on every unordered pair of ``floor``'s sessions; rows written as they come.

    ``params`` (None: the defaults) are the default method's settings.
    """
    settings = {} if params is None else {"params": params}
    names = sessions(folder, floor)
    grids = {name: merging.load_map(folder / f"{name}.yaml") for name in names}
    answers: list[Answer] = []
    for first, second in itertools.combinations(names, 2):
        for method in methods:
            start = time.perf_counter()
            options = settings if method == DEFAULT_METHOD else {}
            result = merging.estimate_transform(grids[first], grids[second], method=method,
                                                rng=0, **options)  # fmt: skip
            seconds = time.perf_counter() - start
            answer = Answer(floor, first, second, method, seconds, result)
            answers.append(answer)
            writer.writerow({
                "floor": floor, "first": first, "second": second, "method": method,
                "accepted": answer.accepted, "confidence": round(result.confidence, 4),
                "seconds": round(seconds, 4), "matrix": json.dumps(result.matrix.tolist()),
                "reason": answer.reason,
            })  # fmt: skip
            handle.flush()
        print(f"  {floor}: {first} | {second}", end="\r", file=sys.stderr)
    print(file=sys.stderr)
    return answers


def cycles(answers: list[Answer], walls: dict[str, NDArray]) -> list[tuple[str, str, str, float]]:
    """``(a, b, c, error)`` for every three sessions whose three pairs are all accepted."""
    found = {(x.first, x.second): x.matrix for x in answers if x.accepted}
    names = sorted({x.first for x in answers} | {x.second for x in answers})
    closed = []
    for a, b, c in itertools.combinations(names, 3):
        if (a, b) in found and (b, c) in found and (a, c) in found:
            chained = found[(a, b)] @ found[(b, c)]
            error = transform_error(chained, found[(a, c)], walls[c])[0]
            closed.append((a, b, c, float(error)))
    return closed


def refused_against_cycles(
    answers: list[Answer], walls: dict[str, NDArray]
) -> list[tuple[str, str, float | None, str]]:
    """``(a, c, error, reason)`` for every refused pair: how far (cells RMS over ``c``'s
    walls, the median over every ``b``) its answer lies from the chain of two accepted
    answers ``a <- b <- c``; None when no such chain exists.

    A refused answer within a few tens of cells of the chains (the report's
    ``--look-cells``) is a right answer the verdict did not vouch for; one
    beyond :data:`WRONG_CELLS`, a wrong answer rightly refused. So the refusals
    split, without a known truth, into what the verdict's caution costs and what
    the search misses.
    """
    found = {(x.first, x.second): x.matrix for x in answers if x.accepted}

    def accepted(x: str, y: str) -> NDArray | None:
        if (x, y) in found:
            return found[(x, y)]
        return None if (y, x) not in found else np.linalg.inv(found[(y, x)])

    names = sorted({x.first for x in answers} | {x.second for x in answers})
    checked = []
    for answer in answers:
        if answer.accepted:
            continue
        a, c = answer.first, answer.second
        errors = []
        for b in names:
            ab, bc = accepted(a, b), accepted(b, c)
            if b in (a, c) or ab is None or bc is None:
                continue
            errors.append(transform_error(ab @ bc, answer.matrix, walls[c])[0])
        median = float(np.median(errors)) if errors else None
        checked.append((a, c, median, answer.reason))
    return checked


def linked_against_answers(
    answers: list[Answer], names: list[str], grids: dict[str, NDArray]
) -> tuple[tuple[tuple[int, ...], ...], list[tuple[bool, float | None]]]:
    """One method's answers on one floor linked at once (:func:`merging.link_maps`).

    Returns the linking's groups (indices into ``names``) and, per answer, whether it
    was accepted and how far (cells RMS over map 2's walls) it lies from the transform
    the linking gives its pair; None when the linking leaves the two sessions apart.
    """
    index = {name: k for k, name in enumerate(names)}
    pairs = {}
    for answer in answers:
        pairs[(index[answer.first], index[answer.second])] = answer.result
    linking = merging.link_maps([grids[name] for name in names], pairs)
    distances: list[tuple[bool, float | None]] = []
    for answer in answers:
        relative = linking.relative(index[answer.first], index[answer.second])
        distance = None
        if relative is not None:
            distance = float(transform_error(relative, answer.matrix, grids[answer.second])[0])
        distances.append((answer.accepted, distance))
    return linking.groups, distances


def linking_table(linked: dict[tuple[str, str], tuple], look: float) -> list[str]:
    """The report's section on the linking (:func:`linked_against_answers`)."""
    lines = [
        "",
        "Each floor's sessions linked from the method's answers at once "
        "(`merging.link_maps`, as `merging.merge_all` does): the largest group, the pairs "
        f"the linking places, and the answers within {look:.0f} cells of the transform "
        "it gives their pair.",
        "",
        "| floor | method | sessions | largest group | pairs placed | "
        f"accepted within {look:.0f} | refused within {look:.0f} |",
        "|---|---|---|---|---|---|---|",
    ]
    for (floor, method), (groups, distances) in linked.items():
        placed = [(accepted, d) for accepted, d in distances if d is not None]
        accepted = [d for ok, d in placed if ok]
        refused = [d for ok, d in placed if not ok]
        largest = max((len(g) for g in groups), default=0)
        lines.append(
            f"| {floor} | {method} | {sum(len(g) for g in groups)} | {largest} | "
            f"{len(placed)} of {len(distances)} | {_within(accepted, look)} | "
            f"{_within(refused, look)} |"
        )
    return lines


def _within(distances: list[float], look: float) -> str:
    """``"k of n"``: how many of ``distances`` are at most ``look``; ``-`` for none."""
    if not distances:
        return "-"
    return f"{sum(d <= look for d in distances)} of {len(distances)}"


def overlay(first: NDArray, second: NDArray, matrix: NDArray, path: Path) -> None:
    """Save map 1's walls (black) and map 2's placed by ``matrix`` (red) on map 1's open space."""
    from PIL import Image

    rows, cols = first.shape
    image = np.full((rows, cols, 3), 255, dtype=np.uint8)
    image[first == 0] = (230, 230, 230)
    image[first > 50] = (0, 0, 0)
    ys, xs = np.nonzero(second > 50)
    placed = np.column_stack([xs, ys, np.ones(len(xs))]) @ matrix.T
    x, y = np.rint(placed[:, 0]).astype(int), np.rint(placed[:, 1]).astype(int)
    inside = (x >= 0) & (x < cols) & (y >= 0) & (y < rows)
    image[y[inside], x[inside]] = (215, 25, 28)
    drawn_rows, drawn_cols = np.nonzero((image != 255).any(axis=2))
    if len(drawn_rows):  # the maps' part of the canvas, with a margin
        low_row, low_col = max(drawn_rows.min() - 20, 0), max(drawn_cols.min() - 20, 0)
        image = image[low_row : drawn_rows.max() + 21, low_col : drawn_cols.max() + 21]
    Image.fromarray(image[::-1]).save(path)  # row 0 of the grid is the bottom


def report(
    answers: list[Answer],
    closed: dict[tuple[str, str], list],
    refused: dict[tuple[str, str], list],
    look: float,
    linked: dict[tuple[str, str], tuple] | None = None,
) -> list[str]:
    """The Markdown report: per floor and method, acceptance, how the cycles close, how
    the refused answers lie against them and, given ``linked``
    (:func:`linked_against_answers` per floor and method), the linking's section."""
    lines = [
        "| floor | method | pairs | accepted | cycles | median error (cells) | max | "
        f"above {look:.0f} | above {WRONG_CELLS:.0f} (a wrong answer) | median s |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    flagged = []
    for (floor, method), triples in closed.items():
        mine = [x for x in answers if x.floor == floor and x.method == method]
        errors = np.array([t[3] for t in triples])
        median = f"{np.median(errors):.1f}" if len(errors) else "-"
        worst = f"{errors.max():.1f}" if len(errors) else "-"
        seconds = np.median([x.seconds for x in mine])
        lines.append(
            f"| {floor} | {method} | {len(mine)} | {sum(x.accepted for x in mine)} | "
            f"{len(triples)} | {median} | {worst} | {int((errors > look).sum())} | "
            f"{int((errors > WRONG_CELLS).sum())} | {seconds:.3f} |"
        )
        flagged += [(floor, method, *t) for t in triples if t[3] > look]
    if flagged:
        lines += ["", f"Cycles missing by more than {look:.0f} cells:", ""]
        lines += [f"- {f} {m}: {a} -> {b} -> {c}: {e:.1f} cells" for f, m, a, b, c, e in flagged]
    lines += [
        "",
        "Refused pairs against the chains of two accepted answers around them (cells, the "
        f"median over the chains): within {look:.0f} a right answer the verdict did not vouch "
        f"for, above {WRONG_CELLS:.0f} a wrong answer rightly refused.",
        "",
        f"| floor | method | refused | within {look:.0f} | {look:.0f}-{WRONG_CELLS:.0f} | "
        f"above {WRONG_CELLS:.0f} | no chain |",
        "|---|---|---|---|---|---|---|",
    ]
    for (floor, method), checked in refused.items():
        errors = np.array([e for _, _, e, _ in checked if e is not None])
        near, far = int((errors <= look).sum()), int((errors > max(look, WRONG_CELLS)).sum())
        lines.append(
            f"| {floor} | {method} | {len(checked)} | {near} | {len(errors) - near - far} | "
            f"{far} | {len(checked) - len(errors)} |"
        )
    return lines + (linking_table(linked, look) if linked else [])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    parser.add_argument("--floors", nargs="+", default=list(FLOORS), choices=list(FLOORS))
    parser.add_argument("--methods", nargs="+", default=["tomographic"])
    parser.add_argument("--look-cells", type=positive_float, default=30.0,
                        help="name the cycles missing by more than this (cells RMS)")  # fmt: skip
    parser.add_argument("--overlays", action="store_true",
                        help="draw the accepted pairs of the cycles named")  # fmt: skip
    add_merger_argument(parser)
    parser.add_argument("--out", type=Path, default=Path("results/bench_cycles"))
    args = parser.parse_args(argv)
    if args.look_cells >= WRONG_CELLS:
        parser.error(
            f"--look-cells {args.look_cells:g} must be below {WRONG_CELLS:.0f}, the miss "
            "beyond which an answer counts as wrong"
        )
    params = merger_params(args.merger)
    folder = shared_maps()
    unknown = sorted(set(args.methods) - set(merging.available_methods()))
    if unknown:
        print(f"error: unknown method(s) {unknown}; choose from {merging.available_methods()}",
              file=sys.stderr)  # fmt: skip
        return 2
    halmstad = folder / "halmstad"
    args.out.mkdir(parents=True, exist_ok=True)
    csv_path = args.out / "pairs.csv"
    answers: list[Answer] = []
    closed: dict[tuple[str, str], list] = {}
    refused: dict[tuple[str, str], list] = {}
    linked: dict[tuple[str, str], tuple] = {}
    with csv_path.open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=["floor", "first", "second", "method",
                                                    "accepted", "confidence", "seconds",
                                                    "matrix", "reason"])  # fmt: skip
        writer.writeheader()
        for floor in args.floors:
            names = sessions(halmstad, floor)
            if len(names) < 3:
                print(f"error: {halmstad} holds {len(names)} sessions of {floor}; a cycle needs 3",
                      file=sys.stderr)  # fmt: skip
                return 1
            found = merge_floor(halmstad, floor, args.methods, writer, handle, params)
            answers += found
            walls = {name: merging.load_map(halmstad / f"{name}.yaml").data for name in names}
            for method in args.methods:
                mine = [x for x in found if x.method == method]
                closed[(floor, method)] = cycles(mine, walls)
                refused[(floor, method)] = refused_against_cycles(mine, walls)
                linked[(floor, method)] = linked_against_answers(mine, names, walls)
                if not args.overlays:
                    continue
                named = {p for t in closed[(floor, method)] if t[3] > args.look_cells
                         for p in ((t[0], t[1]), (t[1], t[2]), (t[0], t[2]))}  # fmt: skip
                for a, b in sorted(named):
                    answer = next(x for x in mine if (x.first, x.second) == (a, b))
                    overlay(walls[a], walls[b], answer.matrix,
                            args.out / f"{method}_{a}_{b}.png")  # fmt: skip
    settings = changed(params)
    listed = ", ".join(f"`{name}={value}`" for name, value in settings.items())
    note = [f"Default merger's settings changed (`--merger`): {listed}.", ""] if settings else []
    lines = ["# Cycles of three on floors without a known truth", "", *note,
             *report(answers, closed, refused, args.look_cells, linked)]  # fmt: skip
    md_path = args.out / "cycles.md"
    md_path.write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    print(f"\nrows: {csv_path}  report: {md_path}")
    return 0


if __name__ == "__main__":
    run_script(main, __file__)
