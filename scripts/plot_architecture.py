"""Draw the architecture figure of the documentation: the three packages and one merge round.

Left, the packages as floors, each importing only the ones below it
(``envs -> tomosim -> merging``), with the rooms each holds. Right, one merge
round from a robot's scan to the fused map in the recording, each step named
by the module that does it.

Usage::

    python scripts/plot_architecture.py [--out docs/figures/architecture.svg]
"""

from __future__ import annotations

import argparse
from pathlib import Path

FLOORS = (
    (
        "envs",
        "PettingZoo environment, vector envs, SB3 adapter, scripted agents",
        ("multi_robot_exploration_v0", "centralised", "vector", "sb3", "scripted_agents"),
    ),
    (
        "tomosim",
        "simulation core, team, exploration, episodes, recording, sweeps, CLI",
        (
            "worlds/",
            "simulation",
            "kernels/",
            "team/",
            "exploration/",
            "episode/",
            "recording/",
            "sweep/",
            "commands/",
        ),
    ),
    (
        "merging",
        "map merging from the grids alone; imports neither tomosim nor envs",
        (
            "tomographic/",
            "evidence/",
            "paper/",
            "linking/",
            "baselines/",
            "evaluation/",
            "grid, mapio, params",
        ),
    ),
)
"""(package, what it holds, its rooms), top floor first."""

ROUND = (
    ("lidar scan", "tomosim.simulation: physics, odometry, a scan per robot"),
    ("own map", "tomosim.mapping: log-odds grid in the robot's start frame"),
    ("merge round", "tomosim.team.merger: every pair of grids, at each merge interval"),
    (
        "estimate",
        "tomosim.team.link_tracking: track a linked pair, else search in the\n"
        "worker (merging.estimate_transform), tracking (tomographic.tracking)",
    ),
    ("confirm and link", "two rounds agree; merging.link_maps: spanning forest"),
    ("fuse", "merging.linking: each map into the root's frame, cell-wise max"),
    ("share", "tomosim.team.sharing: each robot's best map"),
    ("record", "tomosim.recording: maps/, merge/ and world/merged/map in the .rrd"),
)
"""(step, module that does it) of one merge round, in order."""

FLOOR_COLOURS = ("#dbe9f6", "#e3f1dc", "#fbe5d6")
STEP_COLOUR = "#f4f4f4"
EDGE = "#444444"


def draw(out: Path) -> None:
    """Draw the figure and write it to ``out`` (the suffix picks the format)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import FancyArrowPatch, FancyBboxPatch

    plt.rcParams["svg.hashsalt"] = "tomosim"  # the same figure gives the same file
    figure = plt.figure(figsize=(13.6, 6.2))
    axes = figure.add_axes((0, 0, 1, 1))
    axes.set_xlim(0, 13.6)
    axes.set_ylim(0, 6.2)
    axes.axis("off")

    axes.text(0.3, 5.85, "Packages: each imports only those below it", fontsize=12, weight="bold")
    floor_height, top = 1.6, 5.55
    for index, ((name, holds, rooms), colour) in enumerate(zip(FLOORS, FLOOR_COLOURS, strict=True)):
        y = top - (index + 1) * floor_height - index * 0.25
        axes.add_patch(
            FancyBboxPatch(
                (0.3, y),
                5.4,
                floor_height,
                boxstyle="round,pad=0.02,rounding_size=0.08",
                facecolor=colour,
                edgecolor=EDGE,
            )
        )
        axes.text(
            0.45, y + floor_height - 0.3, name, fontsize=13, weight="bold", family="monospace"
        )
        axes.text(0.45, y + floor_height - 0.62, holds, fontsize=8.5)
        line, lines = "", []
        for room in rooms:
            candidate = f"{line}  {room}" if line else room
            if len(candidate) > 58:
                lines.append(line)
                candidate = room
            line = candidate
        lines.append(line)
        for number, text in enumerate(lines):
            axes.text(
                0.45,
                y + floor_height - 0.98 - 0.28 * number,
                text,
                fontsize=8.5,
                family="monospace",
                color="#333333",
            )
        if index < len(FLOORS) - 1:
            axes.add_patch(
                FancyArrowPatch(
                    (3.0, y), (3.0, y - 0.25), arrowstyle="-|>", mutation_scale=12, color=EDGE
                )
            )

    axes.text(
        6.3, 5.85, "One merge round, from a scan to the recording", fontsize=12, weight="bold"
    )
    step_height, gap = 0.5, 0.16
    for index, (step, where) in enumerate(ROUND):
        y = top - 0.1 - (index + 1) * step_height - index * gap
        axes.add_patch(
            FancyBboxPatch(
                (6.3, y),
                7.0,
                step_height,
                boxstyle="round,pad=0.02,rounding_size=0.06",
                facecolor=STEP_COLOUR,
                edgecolor=EDGE,
            )
        )
        axes.text(
            6.42,
            y + step_height / 2,
            f"{index + 1}. {step}",
            fontsize=9.5,
            weight="bold",
            va="center",
        )
        axes.text(7.95, y + step_height / 2, where, fontsize=7.6, va="center", family="monospace")
        if index < len(ROUND) - 1:
            axes.add_patch(
                FancyArrowPatch(
                    (6.6, y), (6.6, y - gap), arrowstyle="-|>", mutation_scale=10, color=EDGE
                )
            )

    out.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(out, metadata={"Date": None} if out.suffix == ".svg" else None)
    plt.close(figure)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--out",
        type=Path,
        default=Path("docs/figures/architecture.svg"),
        help="the file to write (.svg or .png; default: %(default)s)",
    )
    args = parser.parse_args(argv)
    draw(args.out)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
