"""Check that the default merger's confidence separates right merges from wrong ones.

Two kinds of pairs, each with a known truth:

* window pairs cut from real maps (the section 4.1 protocol), right when
  within 2 cells RMS;
* robots' maps from simulated exploration episodes (3 robots, generated
  floors, merged every 50 steps for 400 steps, merging itself switched off
  so the maps grow independently), right when within 1 m and 5 degrees of
  the true relative start pose (the maps are drawn at drifting odometry
  poses, so a right merge is off by the drift).

For each kind it prints how many right merges are accepted, how many wrong
ones are, and the highest confidence of a wrong one: the margin below the
acceptance threshold. Each pair is appended to a CSV file as it is done.

Usage::

    python scripts/calibrate_confidence.py                       # defaults below
    python scripts/calibrate_confidence.py --window-seed 7 --worlds 6 7 8
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import numpy as np

import merging
from merging.evaluation.metrics import transform_error
from merging.evaluation.pairs import cut_window_pairs
from merging.evidence.verify import ACCEPT_CONFIDENCE
from merging.transforms import matrix_to_pose, wrap_angle
from tomosim.commands.script_args import missing_maps, non_negative_int, positive_int, run_script
from tomosim.data import maps_dir, maps_missing
from tomosim.episode import EpisodeConfig, load_world
from tomosim.exploration import FrontierPolicy
from tomosim.frames import pose_matrix
from tomosim.team import TeamConfig, TeamSession

WINDOW_RIGHT_CELLS = 2.0
"""A window merge is right within this RMS error (the benchmark's bar)."""
EPISODE_RIGHT_M = 1.0
"""A merge of robots' maps is right within this translation error: drift makes
right merges a few decimetres off, wrong ones are a room or more off."""
ROUND_STEPS = 50
"""Steps between the pairs taken from an episode."""
EPISODE_STEPS = 400
"""Length of each episode."""
ROBOTS = 3
"""Robots per episode."""
FIELDS = ("kind", "source", "right", "accepted", "confidence", "error")


def window_rows(names: list[str], count: int, seed: int):
    folder = maps_dir()
    if folder is None:
        raise SystemExit(f"error: {maps_missing()}")
    for name in names:
        whole = merging.load_map(folder / f"{name}.yaml")
        for index, pair in enumerate(cut_window_pairs(whole.data, count=count, rng=seed)):
            result = merging.estimate_transform(pair.map1, pair.map2)
            rms, _ = transform_error(result.matrix, pair.truth, pair.map2)
            yield ("window", f"{name}#{index}", rms <= WINDOW_RIGHT_CELLS, result, rms)


def episode_rows(worlds: list[int]):
    for world_seed in worlds:
        config = EpisodeConfig(world=world_seed, seed=world_seed, robots=ROBOTS,
                               team=TeamConfig(merge=False))  # fmt: skip
        session = TeamSession(load_world(config.world), robots=ROBOTS, config=config.team,
                              rng=config.seed)  # fmt: skip
        policies = [FrontierPolicy() for _ in range(ROBOTS)]
        while session.steps < EPISODE_STEPS:
            sim = session.simulation
            commands = [policy.act(sim.odometry[k].pose, session.best_map(k), scan=sim.scans[k])
                        for k, policy in enumerate(policies)]  # fmt: skip
            session.step(np.array(commands))
            if session.steps % ROUND_STEPS:
                continue
            grids, starts = session.grids(), sim.start_poses
            for i in range(ROBOTS):
                for j in range(i + 1, ROBOTS):
                    result = merging.estimate_transform(grids[i], grids[j])
                    truth = np.linalg.inv(pose_matrix(starts[i])) @ pose_matrix(starts[j])
                    estimate = result.matrix_metres
                    assert estimate is not None
                    error = float(np.hypot(*(estimate[:2, 2] - truth[:2, 2])))
                    turn = abs(float(wrap_angle(matrix_to_pose(estimate)[2]
                                                - matrix_to_pose(truth)[2])))  # fmt: skip
                    right = error <= EPISODE_RIGHT_M and np.degrees(turn) <= 5.0
                    source = f"world {world_seed} step {session.steps} r{i}-r{j}"
                    yield ("episode", source, right, result, error)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--maps", nargs="+", default=["aces3", "intel", "fr079", "brsu_c069"])
    parser.add_argument("--pairs-per-map", type=positive_int, default=40)
    parser.add_argument("--window-seed", type=non_negative_int, default=11)
    parser.add_argument("--worlds", nargs="+", type=non_negative_int, default=[6, 7, 8, 9])
    parser.add_argument("--out", type=Path, default=Path("results/calibrate_confidence.csv"))
    args = parser.parse_args(argv)
    if maps_dir() is None:  # before the results file is emptied
        parser.error(maps_missing())
    problem = missing_maps(args.maps, "--maps")
    if problem is not None:
        parser.error(problem)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    summary: dict[str, dict[str, float]] = {}
    with args.out.open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(FIELDS)
        sources = [window_rows(args.maps, args.pairs_per_map, args.window_seed),
                   episode_rows(args.worlds)]  # fmt: skip
        for rows in sources:
            for kind, source, right, result, error in rows:
                writer.writerow([kind, source, right, result.accepted,
                                 round(result.confidence, 4), round(error, 3)])  # fmt: skip
                handle.flush()
                s = summary.setdefault(kind, {"right": 0, "right_accepted": 0, "wrong": 0,
                                              "wrong_accepted": 0, "max_wrong": 0.0})  # fmt: skip
                if right:
                    s["right"] += 1
                    s["right_accepted"] += result.accepted
                else:
                    s["wrong"] += 1
                    s["wrong_accepted"] += result.accepted
                    s["max_wrong"] = max(s["max_wrong"], result.confidence)
    print(f"acceptance threshold {ACCEPT_CONFIDENCE}")
    print("kind     right  accepted  wrong  wrongly accepted  highest wrong confidence")
    for kind, s in summary.items():
        print(f"{kind:8} {s['right']:5.0f} {s['right_accepted']:9.0f} {s['wrong']:6.0f} "
              f"{s['wrong_accepted']:17.0f} {s['max_wrong']:25.2f}")  # fmt: skip
    print(f"rows: {args.out}")
    return 0


if __name__ == "__main__":
    run_script(main, __file__)
