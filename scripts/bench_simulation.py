"""Benchmark the simulator: robot-steps per second (physics + lidar + mapping).

A robot-step is one robot advanced by one :meth:`tomosim.simulation.Simulation.step`:
its share of the physics, its odometry, a full lidar scan (360 beams by
default, other robots visible) and the log-odds update of its map. Robots
wander under smooth random commands, so they meet walls and each other as in
an episode. Each configuration is timed ``--repeats`` times on one core;
the table gives the median and the spread (min..max), by the wall clock and
by the process's CPU time (``cpu``, steadier when other work loads the machine).

A second table times one scan with the compiled caster the lidar uses, the
numpy caster it was written from, and pymunk's segment queries, the oracle
the tests compare both with. A third times one plan of the frontier policy on
the map one robot has drawn after ``--plan-after`` steps: the compiled
planning kernels against the library calls they give to the bit (coarsening
to planning cells, the distance to the nearest wall, the frontier clusters),
then the whole planning grid and the wavefront over it. With ``--explore``, a
fourth
table follows one robot under the frontier policy on generated floors and
reports the fraction of the free space it has mapped against the steps taken.

Usage::

    python scripts/bench_simulation.py [--robots 1 3 8] [--steps 300] [--repeats 5]
    python scripts/bench_simulation.py --explore 0 1 2 --budget 3000
"""

from __future__ import annotations

import argparse
import statistics
import time
import timeit

import numpy as np
from scipy import ndimage

from tomosim.commands.script_args import non_negative_int, positive_int, run_script
from tomosim.evaluation import coverage
from tomosim.exploration import FrontierPolicy, PlannerConfig, coarsen, frontier_clusters
from tomosim.exploration.planning import OCCUPIED_CELL, Wavefront, planning_grid
from tomosim.kernels.planning import block_states, distances_to_walls, frontier_groups
from tomosim.lidar import LidarConfig
from tomosim.lidar_oracle import cast_pymunk
from tomosim.ray_geometry import cast_segments, cull_segments, segment_bounds
from tomosim.simulation import Simulation, SimulationConfig
from tomosim.worlds import generate_floorplan

WORLD_SEED = 7
"""The generated world every run uses."""
COMMAND_HOLD_STEPS = 10
"""Steps between changes of a robot's random turn command."""
WARMUP_STEPS = 20
"""Untimed steps before each timed run (first-call costs, map allocation)."""


def wander(sim: Simulation, steps: int, rng: np.random.Generator) -> tuple[float, float]:
    """Run ``steps`` steps of smooth random driving; returns the wall-clock and CPU
    seconds taken."""
    commands = np.column_stack([np.full(sim.count, 0.8), np.zeros(sim.count)])
    start, cpu = time.perf_counter(), time.process_time()
    for step in range(steps):
        if step % COMMAND_HOLD_STEPS == 0:
            commands[:, 1] = rng.uniform(-1.0, 1.0, sim.count)
        sim.step(commands)
    return time.perf_counter() - start, time.process_time() - cpu


def bench_simulation(
    robots: int, steps: int, repeats: int, beams: int
) -> tuple[list[float], list[float]]:
    """Robot-steps per second of ``repeats`` fresh runs with ``robots`` robots, by the wall
    clock and by CPU time (the steadier figure on a machine loaded by other work)."""
    world = generate_floorplan(WORLD_SEED)
    config = SimulationConfig(lidar=LidarConfig(beams=beams))
    rates, cpu_rates = [], []
    for repeat in range(repeats):
        sim = Simulation(world, robots=robots, config=config, rng=repeat)
        rng = np.random.default_rng(repeat)
        wander(sim, WARMUP_STEPS, rng)
        seconds, cpu_seconds = wander(sim, steps, rng)
        rates.append(robots * steps / seconds)
        cpu_rates.append(robots * steps / max(cpu_seconds, 1e-9))
    return rates, cpu_rates


def bench_lidar(scans: int, beams: int) -> tuple[float, float, float]:
    """Microseconds per noise-free scan: (compiled kernel, numpy caster, pymunk queries)."""
    world = generate_floorplan(WORLD_SEED)
    sim = Simulation(
        world, robots=3, config=SimulationConfig(lidar=LidarConfig(beams=beams)), rng=0
    )
    poses = world.sample_free_poses(scans, clearance=0.5, rng=1)
    lidar = sim.lidar
    cfg = lidar.config
    angles = cfg.angles()
    bounds = segment_bounds(lidar.walls)
    lidar.true_ranges(poses[0])  # compiled already, or compiled now: not timed
    start = time.perf_counter()
    for pose in poses:
        lidar.true_ranges(pose)
    kernel_us = (time.perf_counter() - start) / scans * 1e6
    start = time.perf_counter()
    for pose in poses:
        near = lidar.walls[cull_segments(pose[:2], bounds, cfg.max_range)]
        cast_segments(
            pose[:2], pose[2] + cfg.first_angle, cfg.increment, cfg.beams, near, cfg.max_range
        )
    numpy_us = (time.perf_counter() - start) / scans * 1e6
    start = time.perf_counter()
    for pose in poses:
        cast_pymunk(sim.physics.space, pose, angles, cfg.max_range)
    pymunk_us = (time.perf_counter() - start) / scans * 1e6
    return kernel_us, numpy_us, pymunk_us


def bench_plan(after: int, repeats: int) -> tuple[tuple[int, int], dict[str, float]]:
    """Median milliseconds of each stage of one plan on the map one robot has drawn
    after ``after`` steps of exploring, and the planning grid's shape."""
    world = generate_floorplan(WORLD_SEED)
    sim = Simulation(world, robots=1, rng=0)
    policy = FrontierPolicy()
    for _ in range(after):
        command = policy.act(sim.odometry_poses[0], sim.grid(0), scan=sim.scans[0])
        sim.step(command[None])
    grid, config = sim.grid(0), PlannerConfig()
    factor = max(1, round(config.resolution / grid.resolution))
    planning = planning_grid(grid, config)
    occupied = planning.state == OCCUPIED_CELL
    # The robot's own cell may lie within the inflation; any passable cell starts a wavefront.
    rows, cols = np.nonzero(np.isfinite(planning.costs))
    start = (int(cols[len(cols) // 2]), int(rows[len(rows) // 2]))
    stages = {
        "coarsen (numpy)": lambda: coarsen(
            grid.data, factor, free_below=config.free_below, occupied_from=config.occupied_from
        ),
        "block_states (compiled)": lambda: block_states(
            grid.data, factor, config.free_below, config.occupied_from
        ),
        "distance_transform_edt (scipy)": lambda: ndimage.distance_transform_edt(~occupied),
        "distances_to_walls (compiled)": lambda: distances_to_walls(occupied),
        "frontier_clusters (scipy)": lambda: frontier_clusters(planning.state),
        "frontier_groups (compiled)": lambda: frontier_groups(planning.state),
        "planning_grid": lambda: planning_grid(grid, config),
        "Wavefront": lambda: Wavefront(planning, start),
    }
    medians = {}
    for name, run in stages.items():
        run()  # compiled already, or compiled now: not timed
        medians[name] = 1000 * float(np.median(timeit.repeat(run, number=1, repeat=repeats)))
    return planning.state.shape, medians


def explore(seed: int, budget: int, checkpoints: list[int]) -> tuple[list[float], int]:
    """Coverage at each checkpoint of one robot exploring floor ``seed``, and the
    step at which the policy finished (``budget`` if it did not)."""
    world = generate_floorplan(seed)
    sim = Simulation(world, robots=1, rng=seed)
    policy = FrontierPolicy()
    fractions = []
    finished = budget
    for step in range(1, budget + 1):
        if not policy.finished:
            command = policy.act(sim.odometry_poses[0], sim.grid(0), scan=sim.scans[0])
            sim.step(command[None])
        elif finished == budget:
            finished = step - 1
        if step in checkpoints:
            fractions.append(coverage(world, sim.grid(0), sim.start_poses[0]))
    return fractions, finished


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", type=positive_int, nargs="+", default=[1, 3, 8])
    parser.add_argument("--steps", type=positive_int, default=300, help="timed steps per run")
    parser.add_argument("--repeats", type=positive_int, default=5, help="runs per robot count")
    parser.add_argument("--beams", type=positive_int, default=360)
    parser.add_argument("--scans", type=positive_int, default=200, help="scans for the lidar table")
    parser.add_argument(
        "--plan-after", type=positive_int, default=600, help="steps explored before the plan table"
    )
    parser.add_argument("--plans", type=positive_int, default=50, help="timings per plan stage")
    parser.add_argument(
        "--explore",
        type=non_negative_int,
        nargs="*",
        default=[],
        help="floor seeds for the exploration table (none: skip it)",
    )
    parser.add_argument(
        "--budget", type=positive_int, default=3000, help="exploration steps (at least 6)"
    )
    args = parser.parse_args()
    if args.budget < 6:  # coverage is reported at six sixths of the budget
        parser.error(f"--budget {args.budget}: give at least 6 steps")
    world = generate_floorplan(WORLD_SEED)
    print(
        f"world: {world.name}, {len(world.walls)} wall segments; {args.beams} beams; "
        f"{args.steps} steps x {args.repeats} repeats"
    )
    print(
        f"{'robots':>6} {'steps':>6} {'robot-steps/s median':>21} {'min':>8} {'max':>8}"
        f" {'cpu median':>10} {'min':>8} {'max':>8}"
    )
    for robots in args.robots:
        rates, cpu = bench_simulation(robots, args.steps, args.repeats, args.beams)
        print(
            f"{robots:>6} {args.steps:>6} {statistics.median(rates):>21.0f} "
            f"{min(rates):>8.0f} {max(rates):>8.0f} {statistics.median(cpu):>10.0f} "
            f"{min(cpu):>8.0f} {max(cpu):>8.0f}"
        )
    kernel_us, numpy_us, pymunk_us = bench_lidar(args.scans, args.beams)
    print(f"\nlidar, one {args.beams}-beam scan without noise:")
    print(f"  compiled kernel (tomosim.kernels)  {kernel_us:8.0f} us")
    print(f"  numpy angular-sweep caster         {numpy_us:8.0f} us")
    print(f"  pymunk segment_query_first         {pymunk_us:8.0f} us")
    shape, medians = bench_plan(args.plan_after, args.plans)
    print(
        f"\none plan after {args.plan_after} steps of one robot, {shape[0]} x {shape[1]} "
        f"planning cells, median of {args.plans}:"
    )
    for name, milliseconds in medians.items():
        print(f"  {name:<34} {milliseconds:8.2f} ms")
    if args.explore:
        checkpoints = [args.budget * k // 6 for k in range(1, 7)]
        print("\nexploration, one robot, default 30 m x 20 m floor: fraction of free space mapped")
        print(f"{'seed':>6} " + " ".join(f"{c:>6}" for c in checkpoints) + f" {'done at':>8}")
        for seed in args.explore:
            fractions, finished = explore(seed, args.budget, checkpoints)
            print(f"{seed:>6} " + " ".join(f"{f:>6.3f}" for f in fractions) + f" {finished:>8}")


if __name__ == "__main__":
    run_script(main, __file__)
