"""Reproduce the paper's comparison (Tables 2 and 3, Figures 3-5, 7, 8) on real maps.

Every registered method, the paper's pipeline with and without its
Monte-Carlo step ("Proposed w/o MCO" of Table 3), and the baselines of
:mod:`merging.baselines` run on the same pairs, one after the other:

* **Sim.** The protocol of section 4.1: window pairs cut from one real map,
  the second turned by a random angle and shifted; the truth is known
  exactly. ``aces3`` is the paper's building; further maps give extra rows.
* **Exp. ap_hill.** The four robots' maps of one building, nearly in one
  frame; the reference of each pair of robots is found near the identity,
  and map 2 is given random poses.
* **Exp. halmstad.** Separate mapping sessions of one floor, in unrelated
  frames, cropped and coarsened (``--halmstad-scale``); the reference of a
  pair is the answer with the highest acceptance index that a method of
  another family agrees with (check it by eye on the overlays this script
  draws). Pairs without such agreement are not judged.

Per method and row the report gives the mean and standard deviation of the
matching index Ψ (eq. 31) and of the time (layout of Tables 2 and 3), the
success rate (error within the row's tolerance), the share accepted and the
share accepted but wrong, and draws Figures 7-8 (overlap and per-pair Ψ,
sorted by overlap) for the Sim. and Exp. rows and Figures 3-5 (sinograms and
partial-sinogram correlations) for the first Sim. pair. The work is done by
the modules of ``scripts/paper_comparison/``; this file parses the options
and runs them in order.

Everything random is seeded by ``--seed``: a rerun gives the same pairs,
poses and results; only the measured times vary.

Usage::

    python scripts/reproduce_paper.py                      # the full report (about 8 minutes)
    python scripts/reproduce_paper.py --sim-pairs 10 --extra-maps --ap-hill-poses 1 \\
        --halmstad-sessions 3 --no-docs                     # a quick look
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from paper_comparison.cases import CaseOptions, case_groups
from paper_comparison.contenders import CONTENDERS, DEFAULT_KEY, Contender
from paper_comparison.figures import DOCS_FIGURES, draw_figures
from paper_comparison.plotting import pyplot
from paper_comparison.report import report
from paper_comparison.runner import run_groups
from paper_comparison.study import Study
from paper_comparison.tables import markdown_tables, verdict_lines

from tomosim.commands.script_args import missing_maps, non_negative_int, positive_int, run_script
from tomosim.data import maps_dir, maps_missing

HALMSTAD_FLOORS = ("E5", "F5", "HIH", "KPT4A")
"""The halmstad data set's floors, each mapped in several sessions."""


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    """The command line's options (``argv`` None reads ``sys.argv``)."""
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    parser.add_argument("--sim-maps", nargs="+", default=["aces3"], help="maps of the Sim. row")
    parser.add_argument(
        "--sim-pairs", type=positive_int, default=100, help="window pairs per Sim. map"
    )
    parser.add_argument("--extra-maps", nargs="*", default=["intel"], help="extra Sim. rows")
    parser.add_argument("--extra-pairs", type=positive_int, default=10, help="pairs per extra map")
    parser.add_argument(
        "--ap-hill-poses", type=positive_int, default=2, help="random poses per pair"
    )
    parser.add_argument("--halmstad-floor", default="E5", choices=list(HALMSTAD_FLOORS))
    parser.add_argument(
        "--halmstad-sessions", type=positive_int, default=5, help="sessions (all pairs)"
    )
    parser.add_argument(
        "--halmstad-scale", type=positive_int, default=2, help="cells per coarse cell"
    )
    parser.add_argument("--methods", nargs="+", default=[c.key for c in CONTENDERS])
    parser.add_argument("--seed", type=non_negative_int, default=2020)
    parser.add_argument("--out", type=Path, default=Path("results/paper"))
    parser.add_argument("--docs", type=Path, default=Path("docs"))
    parser.add_argument("--no-docs", action="store_true", help="do not write into --docs")
    args = parser.parse_args(argv)
    if args.halmstad_sessions < 2:
        parser.error(
            f"--halmstad-sessions must be at least 2 (a pair), got {args.halmstad_sessions}"
        )
    return args


def methods_problem(methods: list[str]) -> str | None:
    """What is wrong with ``--methods``, as an error message; None if nothing."""
    choices = [c.key for c in CONTENDERS]
    unknown = sorted(set(methods) - set(choices))
    if unknown:
        return f"unknown method(s) {unknown}; choose from {choices}"
    if DEFAULT_KEY not in methods:
        return f"the {DEFAULT_KEY} method is the one compared; keep it"
    return None


def main(argv: list[str] | None = None) -> int:
    """Run the comparison and write its outputs; returns the exit status."""
    args = parse_args(argv)
    start = time.perf_counter()
    if maps_dir() is None:
        print(f"error: {maps_missing()}", file=sys.stderr)
        return 1
    problem = methods_problem(args.methods) or missing_maps(
        [*args.sim_maps, *args.extra_maps], "--sim-maps/--extra-maps"
    )
    if problem is not None:
        print(f"error: {problem}", file=sys.stderr)
        return 2
    contenders = [c for c in CONTENDERS if c.key in args.methods]
    pyplot()  # fail now, not after the long run, when matplotlib is missing
    args.out.mkdir(parents=True, exist_ok=True)
    study = Study()
    options = CaseOptions(
        sim_maps=tuple(args.sim_maps),
        sim_pairs=args.sim_pairs,
        extra_maps=tuple(args.extra_maps),
        extra_pairs=args.extra_pairs,
        ap_hill_poses=args.ap_hill_poses,
        halmstad_floor=args.halmstad_floor,
        halmstad_sessions=args.halmstad_sessions,
        halmstad_scale=args.halmstad_scale,
        seed=args.seed,
    )
    built = run_groups(
        case_groups(options, study),
        contenders,
        seed=args.seed,
        study=study,
        csv_path=args.out / "rows.csv",
    )
    first_sim = next((cases[0] for name, cases in built if name.startswith("Sim.") and cases), None)
    halmstad = [case for name, cases in built if name.startswith("Exp. halmstad") for case in cases]
    figures = draw_figures(study, contenders, first_sim, halmstad, args.out)
    minutes = (time.perf_counter() - start) / 60
    write_reports(args, study, contenders, figures, command_line(argv), minutes)
    print(markdown_tables(study, contenders))
    print()
    print("\n".join(verdict_lines(study, contenders)))
    print(f"\nreport: {args.out / 'report.md'}  ({minutes:.1f} min)")
    return 0


def command_line(argv: list[str] | None) -> str:
    """The command as typed, for the report's first line."""
    command = "python scripts/reproduce_paper.py" + (" " + " ".join(argv) if argv else "")
    if argv is None and len(sys.argv) > 1:
        command += " " + " ".join(sys.argv[1:])
    return command


def write_reports(
    args: argparse.Namespace,
    study: Study,
    contenders: list[Contender],
    figures: dict[str, str],
    command: str,
    minutes: float,
) -> None:
    """Write ``report.md`` into ``--out`` and, unless ``--no-docs``, a copy into ``--docs``.

    The copy shows only the figures of :data:`DOCS_FIGURES`, copied into
    ``--docs/figures``.
    """
    text = report(study, contenders, figures, command, minutes, "")
    (args.out / "report.md").write_text(text + "\n")
    if args.no_docs:
        return
    (args.docs / "figures").mkdir(parents=True, exist_ok=True)
    shown = {name: caption for name, caption in figures.items() if name in DOCS_FIGURES}
    for name in shown:
        (args.docs / "figures" / name).write_bytes((args.out / name).read_bytes())
    docs_text = report(study, contenders, shown, command, minutes, "figures/")
    (args.docs / "reproduce_paper.md").write_text(docs_text + "\n")


if __name__ == "__main__":
    run_script(main, __file__)
