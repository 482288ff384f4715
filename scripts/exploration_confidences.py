"""How confident the merger is when it accepts right and false matches in exploration.

Exploration on generated floors with the team's settings; every pair estimate
a merge round accepts is a row: its confidence, its rotation and translation
errors against the truth, whether it was the pair's first acceptance in the
episode, whether it was confirmed and whether the linking dropped it, and,
for a pair joining two linked groups, the share of walls on open space
across the join that the linking judged it by (``linking.across_conflict``,
:mod:`merging.linking.across`). A false match is an estimate beyond 5
degrees or 1 m of the truth (:mod:`tomosim.episode.outcome`).

The summary says at which confidences the false matches were accepted, and
for thresholds of :attr:`~tomosim.team.TeamConfig.confirm_at_once_confidence`
how many of the pairs' first right acceptances and of the false matches reach
each: a threshold links the first at once and must leave the second to the
next round, which rarely repeats a false match. Run with
``--team confirm_at_once_confidence=none`` to see every estimate wait, as before
that setting.

Usage::

    python scripts/exploration_confidences.py --worlds 0 1 2 --seeds $(seq 0 63) --out confidences
    python scripts/exploration_confidences.py --team confirm_at_once_confidence=none --out waiting

Rows go to ``<out>/confidences.csv`` as each episode ends; rerunning the same
command goes on from the episodes already there (``<out>/episodes.txt``), and a
run with other settings into the same folder is refused (``<out>/settings.json``).
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from tomosim.commands.floor_episodes import (
    add_floor_episode_arguments,
    check_floor_episode_arguments,
    floor_episode,
)
from tomosim.episode import EpisodeConfig
from tomosim.episode.outcome import GROSS_ROTATION_DEG, GROSS_TRANSLATION_M
from tomosim.episode.runner import run_episode
from tomosim.team import RoundQuality, TeamSession
from tomosim.team.overrides import changed_settings

COLUMNS = (
    "world",
    "seed",
    "step",
    "pair",
    "confidence",
    "rotation_error_deg",
    "translation_error_m",
    "false_match",
    "first_acceptance",
    "confirmed",
    "dropped",
    "conflict_across",
)
"""The rows' columns: one accepted estimate each; ``first_acceptance`` is 1 for the
first round that accepted the pair in its episode; ``dropped`` is 1 when the linking
left a confirmed estimate out as contradicting the others; ``conflict_across`` is the
share of walls on open space the linking judged a confirmed estimate's join of two
groups by (:attr:`merging.Linking.across`), empty when it judged none (an estimate
not confirmed, a join of two single maps, a cycle, maps that bend, too few walls
meeting)."""
THRESHOLDS = (0.65, 0.7, 0.75, 0.8, 0.85, 0.9, 0.95)
"""Confidences the summary counts the first right acceptances and false matches at."""
TEAM_EXAMPLE = "confirm_at_once_confidence=none"
"""The ``--team`` setting the help and a malformed ``--team`` name as an example."""
SETTINGS_FILE = "settings.json"
"""The file in ``--out`` naming the settings its episodes ran with; a run into a folder
whose episodes ran with others is refused rather than mixed."""


def episode_rows(world: int, seed: int, config: EpisodeConfig) -> list[dict[str, Any]]:
    """One episode's rows (:data:`COLUMNS`), in round order."""
    across: dict[tuple[int, str], float] = {}

    def keep_shares(session: TeamSession, scored: RoundQuality) -> None:
        """The shares of walls on open space the round's linking judged joins by."""
        for (first, second), share in scored.merge.linking.across.items():
            across[(scored.step, f"r{first}-r{second}")] = share

    metrics = run_episode(config, on_merge=keep_shares)
    rows = []
    seen: set[str] = set()
    for merge in metrics.merges:
        for pair in merge.pairs:
            if not pair.accepted:
                continue
            name = f"r{pair.first}-r{pair.second}"
            false = (
                pair.rotation_error_deg > GROSS_ROTATION_DEG
                or pair.translation_error_m > GROSS_TRANSLATION_M
            )
            rows.append(
                {
                    "world": f"floor{world}",
                    "seed": seed,
                    "step": merge.step,
                    "pair": name,
                    "confidence": round(pair.confidence, 4),
                    "rotation_error_deg": round(pair.rotation_error_deg, 3),
                    "translation_error_m": round(pair.translation_error_m, 3),
                    "false_match": int(false),
                    "first_acceptance": int(name not in seen),
                    "confirmed": int(pair.confirmed),
                    "dropped": int(pair.dropped),
                    "conflict_across": _share(across.get((merge.step, name))),
                }
            )
            seen.add(name)
    return rows


def _share(value: float | None) -> str | float:
    """A share as the rows hold it: rounded, empty when there is none."""
    return "" if value is None else round(value, 4)


def summarise(rows: Sequence[dict[str, Any]], episodes: int) -> str:
    """The Markdown summary of the rows (module docstring)."""
    false = [r for r in rows if int(r["false_match"])]
    first = [r for r in rows if int(r["first_acceptance"]) and not int(r["false_match"])]
    first_right = np.array([float(r["confidence"]) for r in first])
    lines = [
        f"episodes: {episodes}; {len(rows)} accepted estimates, {len(false)} false matches "
        f"(beyond {GROSS_ROTATION_DEG:g} deg or {GROSS_TRANSLATION_M:g} m), "
        f"{sum(int(r['confirmed']) for r in false)} of them confirmed, "
        f"{sum(int(r['confirmed']) and not int(r.get('dropped') or 0) for r in false)} "
        "of those kept by the linking",
        "",
    ]
    if false:
        lines += [
            "| false match | step | pair | confidence | rotation [deg] | translation [m] "
            "| confirmed | dropped | walls on open space across |",
            "|---|---:|---|---:|---:|---:|---:|---:|---:|",
        ]
        for r in sorted(false, key=lambda r: -float(r["confidence"])):
            share = r.get("conflict_across", "")
            across = "-" if share in ("", None) else f"{float(share):.3f}"
            lines.append(
                f"| {r['world']} seed {r['seed']} | {r['step']} | {r['pair']} | "
                f"{float(r['confidence']):.3f} | {float(r['rotation_error_deg']):.1f} | "
                f"{float(r['translation_error_m']):.1f} | {r['confirmed']} | "
                f"{r.get('dropped', '')} | {across} |"
            )
        lines.append("")
    lines += _across_lines(rows)
    if len(first_right):
        quartiles = np.percentile(first_right, [25, 50, 75])
        lines += [
            f"first right acceptances of a pair: {len(first_right)}, confidence quartiles "
            + ", ".join(f"{q:.3f}" for q in quartiles),
            "",
            "| confidence at least | first right acceptances | false matches |",
            "|---:|---:|---:|",
        ]
        for threshold in THRESHOLDS:
            right = np.mean(first_right >= threshold)
            wrong = sum(float(r["confidence"]) >= threshold for r in false)
            lines.append(f"| {threshold:.2f} | {right:.1%} | {wrong} |")
    return "\n".join(lines)


def _across_lines(rows: Sequence[dict[str, Any]]) -> list[str]:
    """The shares of walls on open space across the joins of right estimates and of
    false matches (those with a share): what ``linking.across_conflict`` is set between."""
    shares: dict[bool, list[float]] = {True: [], False: []}
    for r in rows:
        if r.get("conflict_across") not in ("", None):
            shares[bool(int(r["false_match"]))].append(float(r["conflict_across"]))
    right, false = np.array(shares[False]), shares[True]
    if not len(right) and not false:
        return []
    line = f"joins of two groups judged across: {len(right)} right estimates"
    if len(right):
        median, high, top = np.percentile(right, [50, 99, 100])
        line += f" (walls on open space: median {median:.3f}, 99 % {high:.3f}, max {top:.3f})"
    listed = ", ".join(f"{v:.3f}" for v in sorted(false)) if false else "-"
    return [line + f", {len(false)} false matches ({listed})", ""]


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_floor_episode_arguments(parser, seeds=range(16), team_example=TEAM_EXAMPLE)
    parser.add_argument("--workers", type=int, default=2, help="episodes run at a time")
    parser.add_argument("--out", type=Path, default=Path("confidences"))
    args = parser.parse_args(argv)
    check_floor_episode_arguments(parser, args, team_example=TEAM_EXAMPLE)
    if args.workers < 1:
        parser.error(f"--workers {args.workers}: give at least 1")
    return args


def run_settings(args: argparse.Namespace) -> dict[str, Any]:
    """What makes one folder's episodes comparable: the team settings changed from the
    defaults, the team size, the policy and the step cap."""
    team = json.loads(json.dumps(changed_settings(args.team)))
    return {"team": team, "robots": args.robots, "policy": args.policy, "steps": args.steps}


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "confidences.csv"
    done_path = args.out / "episodes.txt"
    done = set(done_path.read_text(encoding="utf-8").split()) if done_path.exists() else set()
    settings_path, settings = args.out / SETTINGS_FILE, run_settings(args)
    if done and settings_path.exists():
        before = json.loads(settings_path.read_text(encoding="utf-8"))
        if before != settings:
            raise SystemExit(
                f"{args.out} holds episodes run with {before}, not {settings}; give another "
                "--out for these settings"
            )
    settings_path.write_text(json.dumps(settings, indent=2) + "\n", encoding="utf-8")
    kept = []
    if path.exists():  # rows of an episode that did not finish writing are left out
        with path.open(newline="", encoding="utf-8") as handle:
            reader = csv.DictReader(handle)
            if done and tuple(reader.fieldnames or ()) != COLUMNS:
                raise SystemExit(
                    f"{path} was written by an earlier version of this script, without the "
                    f"columns {', '.join(c for c in COLUMNS if c not in (reader.fieldnames or ()))}"
                    "; give another --out"
                )
            kept = [r for r in reader if f"{r['world']}/{r['seed']}" in done]
    with path.open("w", newline="", encoding="utf-8") as handle:
        writer = csv.DictWriter(handle, fieldnames=COLUMNS)
        writer.writeheader()
        writer.writerows(kept)
    wanted = [(w, s) for s in args.seeds for w in args.worlds if f"floor{w}/{s}" not in done]
    with ProcessPoolExecutor(args.workers) as pool:
        futures = {
            (world, seed): pool.submit(episode_rows, world, seed, floor_episode(args, world, seed))
            for world, seed in wanted
        }
        for (world, seed), future in futures.items():
            rows = future.result()
            with path.open("a", newline="", encoding="utf-8") as handle:
                csv.DictWriter(handle, fieldnames=COLUMNS).writerows(rows)
            with done_path.open("a", encoding="utf-8") as handle:  # after its rows: resumable
                handle.write(f"floor{world}/{seed}\n")
            print(f"floor{world} seed {seed}: {len(rows)} accepted", file=sys.stderr)
    keys = {f"floor{w}/{s}" for s in args.seeds for w in args.worlds}
    with path.open(newline="", encoding="utf-8") as handle:
        rows = [r for r in csv.DictReader(handle) if f"{r['world']}/{r['seed']}" in keys]
    report = summarise(rows, len(keys))
    (args.out / "confidences.md").write_text(report + "\n", encoding="utf-8")
    print(report)
    print(f"\nrows: {path}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
