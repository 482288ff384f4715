"""Study: does periodic map merging speed up team exploration?

The same episodes (same worlds, robot counts and seeds, so the same start
poses) are run with merging on and off (:func:`tomosim.episode.run_episode`
with the built-in frontier policy). With merging on, a robot whose map is
linked to teammates' plans on the team's map and so leaves what they have
seen to them; with merging off every robot explores alone. For each episode
the script records the simulated time until the team knows ``--target`` of
the free space (90 % by default), the final coverage, and the errors of the
merges against the simulator's truth.

Rows are appended to a CSV as each episode ends (``--resume`` skips the rows
already there, so ``--resume`` after a complete run only redraws the table and
the plot); at the end a Markdown table and a PNG plot summarise them.

Usage::

    python scripts/study_merging.py                       # defaults: about 10-15 min here
    python scripts/study_merging.py --worlds 0 --robots 2 3 --seeds 0 1 --steps 1500
"""

from __future__ import annotations

import argparse
import csv
import math
import statistics
import time
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from tomosim.data import maps_dir
from tomosim.episode import EpisodeConfig, EpisodeMetrics, run_episode
from tomosim.simulation import SimulationConfig

OUTPUT = Path(__file__).resolve().parents[1] / "docs" / "figures"
"""Where the CSV, Markdown table and plot go by default."""
STEM = "study_merging"
"""File name of the outputs, before the suffix."""
WRONG_ROTATION_DEG = 5.0
"""An accepted estimate off by more than this many degrees counts as a wrong merge
(odometry drift never turns a right merge this far)."""
WRONG_TRANSLATION_M = 1.0
"""Same, for metres of translation error."""
FIELDS = (
    "world",
    "robots",
    "seed",
    "merge",
    "steps",
    "steps_to_target",
    "seconds_to_target",
    "coverage",
    "stop_reason",
    "estimates",
    "accepted",
    "confirmed",
    "wrong_accepted",
    "confirmed_rotation_max_deg",
    "confirmed_translation_max_m",
    "confirmed_translation_median_m",
    "wall_seconds",
)


def resolve_world(token: str) -> str:
    """A world spec: a seed, ``aces3`` (or another name in the shared maps), or a YAML path."""
    if token.isdigit() or token.endswith((".yaml", ".yml")):
        return token
    folder = maps_dir()
    if folder is None:
        raise SystemExit(
            f"world {token!r}: the shared maps folder was not found (set TOMOSIM_MAPS)"
        )
    path = folder / f"{token}.yaml"
    if not path.is_file():
        raise SystemExit(f"world {token!r}: no {path}")
    return str(path)


def world_label(token: str) -> str:
    """Short name of a world in tables: ``floor 0``, ``aces3``."""
    return f"floor {token}" if token.isdigit() else Path(token).stem


def row_of(label: str, config: EpisodeConfig, metrics: EpisodeMetrics) -> dict[str, Any]:
    """One CSV row of an episode."""
    reached = metrics.steps_to(config.coverage_target)
    pairs = [p for m in metrics.merges for p in m.pairs]
    accepted = [p for p in pairs if p.accepted]
    confirmed = [p for p in accepted if p.confirmed]
    wrong = [
        p
        for p in accepted
        if p.rotation_error_deg > WRONG_ROTATION_DEG or p.translation_error_m > WRONG_TRANSLATION_M
    ]
    shifts = [p.translation_error_m for p in confirmed]
    return {
        "world": label,
        "robots": config.robots,
        "seed": config.seed,
        "merge": int(config.merge),
        "steps": metrics.steps,
        "steps_to_target": "" if reached is None else reached,
        "seconds_to_target": "" if reached is None else f"{reached * metrics.dt:.1f}",
        "coverage": f"{metrics.coverage:.4f}",
        "stop_reason": metrics.stop_reason,
        "estimates": len(pairs),
        "accepted": len(accepted),
        "confirmed": len(confirmed),
        "wrong_accepted": len(wrong),
        "confirmed_rotation_max_deg": (
            f"{max(p.rotation_error_deg for p in confirmed):.3f}" if confirmed else ""
        ),
        "confirmed_translation_max_m": f"{max(shifts):.3f}" if shifts else "",
        "confirmed_translation_median_m": f"{statistics.median(shifts):.3f}" if shifts else "",
        "wall_seconds": f"{metrics.wall_seconds:.1f}",
    }


def read_rows(path: Path) -> list[dict[str, str]]:
    """The rows of an existing CSV (none when it does not exist)."""
    if not path.is_file():
        return []
    with path.open(newline="") as handle:
        return list(csv.DictReader(handle))


def key(row: dict[str, Any]) -> tuple[str, int, int, int]:
    return (str(row["world"]), int(row["robots"]), int(row["seed"]), int(row["merge"]))


def run_study(args: argparse.Namespace, csv_path: Path) -> list[dict[str, str]]:
    """Run the episodes not yet in the CSV, appending a row after each."""
    done = {key(row) for row in read_rows(csv_path)} if args.resume else set()
    if not args.resume or not csv_path.is_file():
        with csv_path.open("w", newline="") as handle:
            csv.DictWriter(handle, FIELDS).writeheader()
    for token in args.worlds:
        spec = resolve_world(token)
        label = world_label(spec)
        for robots in args.robots:
            for seed in args.seeds:
                for merge in (True, False):
                    if (label, robots, seed, int(merge)) in done:
                        continue
                    config = EpisodeConfig(
                        world=spec,
                        robots=robots,
                        steps=args.steps,
                        merge=merge,
                        merge_interval=args.merge_interval,
                        coverage_target=args.target,
                        seed=seed,
                    )
                    clock = time.perf_counter()
                    metrics = run_episode(config)
                    row = row_of(label, config, metrics)
                    with csv_path.open("a", newline="") as handle:
                        csv.DictWriter(handle, FIELDS).writerow(row)
                    state = "on " if merge else "off"
                    print(
                        f"{label:>10} robots={robots} seed={seed} merge={state} "
                        f"steps to {args.target:.0%}: {row['steps_to_target'] or '-':>5} "
                        f"coverage {row['coverage']} ({time.perf_counter() - clock:.0f} s)",
                        flush=True,
                    )
    return read_rows(csv_path)


def _median(values: Iterable[float]) -> float | None:
    finite = [v for v in values if math.isfinite(v)]
    return statistics.median(finite) if finite else None


def summarise(rows: list[dict[str, str]], cap_seconds: float) -> list[dict[str, Any]]:
    """Per world and robot count: time to the target with and without merging, and errors.

    An episode that never reached the target counts as ``inf`` in the median.
    """
    groups: dict[tuple[str, int], dict[int, list[dict[str, str]]]] = {}
    for row in rows:
        groups.setdefault((row["world"], int(row["robots"])), {}).setdefault(
            int(row["merge"]), []
        ).append(row)
    out = []
    for (world, robots), by_merge in groups.items():
        entry: dict[str, Any] = {"world": world, "robots": robots, "cap": cap_seconds}
        for merge, name in ((1, "on"), (0, "off")):
            mine = by_merge.get(merge, [])
            times = [
                float(r["seconds_to_target"]) if r["seconds_to_target"] else math.inf for r in mine
            ]
            entry[f"time_{name}"] = statistics.median(times) if times else None
            entry[f"reached_{name}"] = sum(1 for t in times if math.isfinite(t))
            entry[f"runs_{name}"] = len(mine)
            entry[f"coverage_{name}"] = _median(float(r["coverage"]) for r in mine)
        merged = by_merge.get(1, [])
        entry["accepted"] = sum(int(r["accepted"]) for r in merged)
        entry["estimates"] = sum(int(r["estimates"]) for r in merged)
        entry["confirmed"] = sum(int(r["confirmed"]) for r in merged)
        entry["wrong"] = sum(int(r["wrong_accepted"]) for r in merged)
        rot = [
            float(r["confirmed_rotation_max_deg"])
            for r in merged
            if r["confirmed_rotation_max_deg"]
        ]
        shift = [
            float(r["confirmed_translation_max_m"])
            for r in merged
            if r["confirmed_translation_max_m"]
        ]
        med = [
            float(r["confirmed_translation_median_m"])
            for r in merged
            if r["confirmed_translation_median_m"]
        ]
        entry["rotation_max"] = max(rot) if rot else None
        entry["translation_max"] = max(shift) if shift else None
        entry["translation_median"] = _median(med)
        out.append(entry)
    return sorted(out, key=lambda e: (e["world"], e["robots"]))


def _time(value: float | None, cap: float) -> str:
    if value is None:
        return "-"
    return f"> {cap:.0f}" if not math.isfinite(value) else f"{value:.1f}"


def markdown(summary: list[dict[str, Any]], target: float) -> str:
    """The study's table in Markdown."""
    lines = [
        f"| world | robots | time to {target:.0%} [s], merging on | merging off | speed-up "
        "| coverage at the end, on / off | accepted / estimates | wrong accepted "
        "| confirmed merges: max rotation error [deg] | max / median translation error [m] |",
        "|---|---:|---:|---:|---:|---|---|---:|---:|---|",
    ]
    for e in summary:
        on, off = e["time_on"], e["time_off"]
        ratio = "-"
        if on is not None and off is not None and math.isfinite(on) and on > 0:
            ratio = f"{off / on:.2f}x" if math.isfinite(off) else f"> {e['cap'] / on:.2f}x"
        rot = "-" if e["rotation_max"] is None else f"{e['rotation_max']:.2f}"
        shift = (
            "-"
            if e["translation_max"] is None
            else f"{e['translation_max']:.3f} / {e['translation_median']:.3f}"
        )
        cov_on = "-" if e["coverage_on"] is None else f"{e['coverage_on']:.3f}"
        cov_off = "-" if e["coverage_off"] is None else f"{e['coverage_off']:.3f}"
        lines.append(
            f"| {e['world']} | {e['robots']} | {_time(on, e['cap'])} | {_time(off, e['cap'])} "
            f"| {ratio} | {cov_on} / {cov_off} | {e['accepted']} / {e['estimates']} "
            f"| {e['wrong']} | {rot} | {shift} |"
        )
    return "\n".join(lines)


def plot(summary: list[dict[str, Any]], target: float, path: Path) -> None:
    """Per world (columns): time to the target (top) and coverage at the end (bottom),
    per robot count, merging on and off; unreached targets are hatched at the cap."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    worlds = sorted({e["world"] for e in summary})
    figure, axes = plt.subplots(
        2, len(worlds), figsize=(5.5 * len(worlds), 6.5), squeeze=False, sharex="col"
    )
    styles = ((-0.2, "on", "tab:blue"), (0.2, "off", "tab:grey"))
    for column, world in enumerate(worlds):
        mine = [e for e in summary if e["world"] == world]
        robots = np.array([e["robots"] for e in mine])
        cap = mine[0]["cap"]
        top, bottom = axes[0, column], axes[1, column]
        for offset, name, colour in styles:
            values = [e[f"time_{name}"] for e in mine]
            heights = [cap if v is None or not math.isfinite(v) else v for v in values]
            bars = top.bar(
                robots + offset, heights, width=0.38, color=colour, label=f"merging {name}"
            )
            for bar, value in zip(bars, values, strict=True):
                if value is None or not math.isfinite(value):
                    bar.set_hatch("//")
                    bar.set_alpha(0.5)
            coverage = [e[f"coverage_{name}"] or 0.0 for e in mine]
            bottom.bar(robots + offset, coverage, width=0.38, color=colour, label=f"merging {name}")
        top.axhline(cap, color="black", lw=0.6, ls=":")
        top.set_ylabel(f"seconds to {target:.0%} coverage")
        top.set_title(f"{world} (hatched: not reached in {cap:.0f} s)", fontsize=10)
        top.legend(fontsize=8)
        top.grid(axis="y", alpha=0.3)
        bottom.axhline(target, color="black", lw=0.6, ls=":")
        bottom.set_ylim(0, 1)
        bottom.set_ylabel("team coverage at the end")
        bottom.set_xlabel("robots")
        bottom.set_xticks(robots)
        bottom.grid(axis="y", alpha=0.3)
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--worlds",
        nargs="+",
        default=["0", "aces3"],
        help="floor plan seeds, names of shared maps or YAML files",
    )
    parser.add_argument("--robots", type=int, nargs="+", default=[2, 3, 4])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0], help="episode seeds")
    parser.add_argument("--steps", type=int, default=2500, help="step cap per episode (0.1 s each)")
    parser.add_argument("--merge-interval", type=int, default=50)
    parser.add_argument("--target", type=float, default=0.9, help="coverage fraction to reach")
    parser.add_argument("--out", type=Path, default=OUTPUT, help="folder of the outputs")
    parser.add_argument("--resume", action="store_true", help="keep the rows already in the CSV")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    csv_path = args.out / f"{STEM}.csv"
    rows = run_study(args, csv_path)
    summary = summarise(rows, cap_seconds=args.steps * SimulationConfig().dt)
    table = markdown(summary, args.target)
    (args.out / f"{STEM}.md").write_text(table + "\n")
    plot(summary, args.target, args.out / f"{STEM}.png")
    print("\n" + table)
    print(f"\nwrote {csv_path}, {args.out / (STEM + '.md')}, {args.out / (STEM + '.png')}")


if __name__ == "__main__":
    main()
