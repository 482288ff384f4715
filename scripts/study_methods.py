"""Study: which merging method helps a team explore, and how does it scale with team size?

Runs a sweep (:mod:`tomosim.sweep`) of the built-in exploration over merge
methods (the tomographic default, the paper's method, the Harris-corner
matcher, which tied the default on the paper's simulated pairs, and merging
off) and team sizes, then writes a Markdown table and a plot of the simulated
time to the coverage target. Rows are appended as episodes finish; rerun with
``--resume`` after an interruption.

Usage::

    python scripts/study_methods.py                         # the defaults below
    python scripts/study_methods.py --executor ray --seeds 0 1 2 3 4 5 6 7
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from tomosim.commands.script_args import non_negative_int, positive_int, run_script
from tomosim.episode import load_world
from tomosim.sweep import EXECUTORS, ResultsFile, SweepPlan, run_sweep

METHODS = ("tomographic", "paper", "harris", "none")
"""The default, the paper's pipeline, the best baseline on simulated pairs, no merging."""


def table(rows: list[dict[str, str]], methods: tuple[str, ...], robots: tuple[int, ...]) -> str:
    lines = [
        "| robots | method | episodes | time to target [s], median (range) | reached "
        "| accepted merges | wrong accepted | median rotation / translation error |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for count in robots:
        for method in methods:
            group = [r for r in rows if r["method"] == method and int(r["robots"]) == count]
            if not group:
                continue
            times = np.array([float(r["time_to_target_s"]) for r in group if r["time_to_target_s"]])
            reached = f"{len(times)}/{len(group)}"
            span = (
                f"{np.median(times):.0f} ({times.min():.0f}-{times.max():.0f})"
                if len(times)
                else "-"
            )
            accepted = sum(int(r["pairs_accepted"]) for r in group)
            wrong = sum(int(r["pairs_wrong"]) for r in group)
            rot = [
                float(r["rotation_error_deg_median"])
                for r in group
                if r["rotation_error_deg_median"]
            ]
            trans = [
                float(r["translation_error_m_median"])
                for r in group
                if r["translation_error_m_median"]
            ]
            errors = f"{np.median(rot):.2f}° / {np.median(trans):.3f} m" if rot else "-"
            lines.append(
                f"| {count} | {method} | {len(group)} | {span} | {reached} | {accepted} | {wrong} "
                f"| {errors} |"
            )
    return "\n".join(lines)


def plot(rows: list[dict[str, str]], methods: tuple[str, ...], robots: tuple[int, ...], path: Path):
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print('no plot: plotting needs matplotlib: pip install "tomosim[plot]"', file=sys.stderr)
        return
    fig, axis = plt.subplots(figsize=(6, 3.8))
    width = 0.8 / len(methods)
    for k, method in enumerate(methods):
        medians = []
        for count in robots:
            group = [r for r in rows if r["method"] == method and int(r["robots"]) == count]
            times = [
                float(r["time_to_target_s"]) if r["time_to_target_s"] else float(r["steps"]) * 0.1
                for r in group
            ]
            medians.append(np.median(times) if times else np.nan)
        axis.bar(np.arange(len(robots)) + k * width, medians, width, label=method)
    axis.set_xticks(np.arange(len(robots)) + width * (len(methods) - 1) / 2)
    axis.set_xticklabels([f"{n} robots" for n in robots])
    axis.set_ylabel("simulated time to target [s]")
    axis.set_title("median time to 90 % coverage (capped episodes count at the cap)", fontsize=9)
    axis.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=100)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--world", default="0", help="a floor-plan seed or a map_server YAML")
    parser.add_argument("--robots", nargs="+", type=positive_int, default=[2, 3, 4])
    parser.add_argument("--methods", nargs="+", default=list(METHODS))
    parser.add_argument("--seeds", nargs="+", type=non_negative_int, default=[0, 1])
    parser.add_argument("--steps", type=positive_int, default=2000)
    parser.add_argument("--executor", choices=EXECUTORS, default="process")
    parser.add_argument("--workers", type=positive_int)
    parser.add_argument("--resume", action="store_true")
    parser.add_argument("--out", type=Path, default=Path("docs/figures/study_methods"))
    args = parser.parse_args(argv)
    plan = SweepPlan(worlds=(args.world,), robots=tuple(args.robots), methods=tuple(args.methods),
                     seeds=tuple(args.seeds), steps=args.steps)  # fmt: skip
    try:  # a bad seed or world is refused before earlier results are removed
        plan.episodes()
        load_world(args.world)
    except (ValueError, FileNotFoundError, TypeError) as error:
        parser.error(str(error))
    csv_path = args.out.with_suffix(".csv")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    if csv_path.exists() and not args.resume:
        csv_path.unlink()

    def progress(row: dict[str, object]) -> None:
        print(f"  {row['key']}: coverage {row['coverage']}, steps {row['steps']}", file=sys.stderr)

    run_sweep(plan, csv_path, executor=args.executor, workers=args.workers, resume=args.resume,
              progress=progress)  # fmt: skip
    rows = ResultsFile(csv_path).rows()
    report = table(rows, tuple(args.methods), tuple(args.robots))
    args.out.with_suffix(".md").write_text(report + "\n")
    plot(rows, tuple(args.methods), tuple(args.robots), args.out.with_suffix(".png"))
    print(report)
    return 0


if __name__ == "__main__":
    run_script(main, __file__)
