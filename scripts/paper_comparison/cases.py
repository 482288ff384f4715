"""Build the pairs of maps to merge, row by row, with their truth.

* **Sim.** The protocol of section 4.1: window pairs cut from one real map
  (:func:`merging.evaluation.pairs.cut_window_pairs`), the second turned by a random
  angle and shifted; the truth is known exactly. ``aces3`` is the paper's
  building; further maps give extra rows.
* **Exp. ap_hill.** The four robots' maps of one building, nearly in one
  frame. The reference transform of each pair of robots is found near the
  identity (:func:`paper_comparison.references.robot_references`); map 2 is
  then given a random pose, so the truth is the reference composed with
  that pose.
* **Exp. halmstad.** Separate mapping sessions of one floor, in unrelated
  frames; their relative truth is unknown. The observed part of each map is
  cropped and coarsened, map 2 gets a random pose, and the truth is left
  None: the runner chooses a reference from the methods' answers
  (:func:`paper_comparison.references.corroborated_reference`).

Each row is built only when it is run (:func:`case_groups`), so a long run
shows its first results early.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

import merging
from merging.evaluation.pairs import cut_window_pairs
from merging.grid import FREE, OCCUPIED, UNKNOWN, free_mask, occupied_mask
from merging.transforms import rigid_matrix, translation_matrix
from merging.warp import warp_cells
from tomosim.data import maps_dir, maps_missing

from .references import robot_references
from .study import Case, Study, Tolerance

MAP_RESOLUTION = 0.05
"""Metres per cell of every map in the shared folder."""
SIM_TOLERANCE = Tolerance(2.0, 180.0, MAP_RESOLUTION)
"""Sim.: the truth is exact, so the project's 2-cell bound applies (the RMS bound
implies the rotation; 180° leaves it to the RMS)."""
AP_HILL_TOLERANCE = Tolerance(4.0, 3.0, MAP_RESOLUTION)
"""Exp. ap_hill: the reference is itself uncertain by a cell or two (see the
cycle check in the report), and a wrong merge is tens of cells off."""
AP_HILL_ROBOTS = 4
"""Robots whose maps the ap_hill data set holds (``ap_hill_robot0`` to ``3``)."""
HALMSTAD_TOLERANCE_METRES = 1.0
"""Exp. halmstad: sessions of one floor disagree by up to about half a metre
(distortion), so answers within 1 m RMS and 3° of the reference agree."""
HALMSTAD_DEGREES = 3.0
"""Rotation tolerance of the halmstad rows, degrees."""
CROP_MARGIN = 10
"""Cells of unknown space kept around a halmstad session's observed part."""
POSE_MARGIN = 30
"""Cells of free canvas around a randomly posed map, and the largest random shift."""

CaseGroup = tuple[str, Callable[[], list[Case]]]
"""A table row's name and the function that builds its cases."""


@dataclass(frozen=True, slots=True)
class CaseOptions:
    """Which rows to build and how many pairs each holds (the script's options).

    ``sim_maps`` get ``sim_pairs`` window pairs each and ``extra_maps``
    ``extra_pairs``; ap_hill gives map 2 ``ap_hill_poses`` random poses per
    ordered pair of robots (0 leaves the row out); halmstad pairs the first
    ``halmstad_sessions`` sessions of ``halmstad_floor`` (fewer than 2 leave
    the row out), coarsened ``halmstad_scale`` cells to one. ``seed`` seeds
    every random draw.
    """

    sim_maps: tuple[str, ...]
    sim_pairs: int
    extra_maps: tuple[str, ...]
    extra_pairs: int
    ap_hill_poses: int
    halmstad_floor: str
    halmstad_sessions: int
    halmstad_scale: int
    seed: int


def case_groups(options: CaseOptions, study: Study) -> list[CaseGroup]:
    """The rows in run order, each with a function building its cases.

    The ap_hill row writes its reference notes into ``study`` when built.
    """
    seed = options.seed
    groups: list[CaseGroup] = [
        *(
            (f"Sim. {m}", lambda m=m: sim_cases(m, options.sim_pairs, seed))
            for m in options.sim_maps
        ),
        *(
            (f"Sim. {m}", lambda m=m: sim_cases(m, options.extra_pairs, seed))
            for m in options.extra_maps
        ),
    ]
    if options.ap_hill_poses > 0:
        groups.append(("Exp. ap_hill", lambda: ap_hill_cases(options.ap_hill_poses, seed, study)))
    if options.halmstad_sessions >= 2:
        floor = options.halmstad_floor
        groups.append(
            (
                f"Exp. halmstad {floor}",
                lambda: halmstad_cases(
                    floor, options.halmstad_sessions, options.halmstad_scale, seed
                ),
            )
        )
    return groups


def shared_maps() -> Path:
    """The folder of real maps (``main`` checks that it exists before any case is built)."""
    folder = maps_dir()
    if folder is None:
        raise FileNotFoundError(maps_missing())
    return folder


def random_pose(
    cells: NDArray[np.int8], rng: np.random.Generator
) -> tuple[NDArray[np.int8], NDArray[np.float64]]:
    """``cells`` turned by a uniform random angle and shifted onto a canvas that holds it.

    Returns the posed grid and the matrix taking ``cells``' cells to its cells.
    """
    rows, cols = cells.shape
    side = int(np.ceil(np.hypot(rows, cols))) + 2 * POSE_MARGIN
    centre = np.array([(cols - 1) / 2, (rows - 1) / 2])
    angle = float(rng.uniform(-np.pi, np.pi))
    shift = rng.uniform(-POSE_MARGIN, POSE_MARGIN, size=2)
    pose = (
        translation_matrix(np.full(2, (side - 1) / 2) + shift)
        @ rigid_matrix(0.0, 0.0, angle)
        @ translation_matrix(-centre)
    )
    return warp_cells(cells, pose, (side, side)), pose


def sim_cases(name: str, count: int, seed: int) -> list[Case]:
    """Section 4.1 window pairs of one map."""
    grid = merging.load_map(shared_maps() / f"{name}.yaml")
    pairs = cut_window_pairs(grid.data, count=count, rng=seed)
    return [
        Case(f"Sim. {name}", "Sim.", f"{name} #{i}", p.map1, p.map2, p.truth, SIM_TOLERANCE)
        for i, p in enumerate(pairs)
    ]


def ap_hill_cases(poses: int, seed: int, study: Study) -> list[Case]:
    """Ordered pairs of the four ap_hill robots' maps, map 2 given ``poses`` random poses."""
    folder = shared_maps()
    maps = [merging.load_map(folder / f"ap_hill_robot{i}.yaml").data for i in range(AP_HILL_ROBOTS)]
    references = robot_references(maps, study.notes.setdefault("Exp. ap_hill", []))
    rng = np.random.default_rng(seed)
    cases = []
    for (i, j), reference in sorted(references.items()):
        for k in range(poses):
            posed, pose = random_pose(maps[j], rng)
            cases.append(
                Case(
                    "Exp. ap_hill",
                    "Exp.",
                    f"robot{j}->robot{i} pose {k}",
                    maps[i],
                    posed,
                    reference @ np.linalg.inv(pose),
                    AP_HILL_TOLERANCE,
                )
            )
    return cases


def coarsen_grid(cells: NDArray[np.int8], factor: int) -> NDArray[np.int8]:
    """Blocks of ``factor`` x ``factor`` cells: occupied if any cell is, else free if any is."""
    if factor == 1:
        return cells
    rows = -(-cells.shape[0] // factor) * factor
    cols = -(-cells.shape[1] // factor) * factor
    padded = np.full((rows, cols), UNKNOWN, dtype=np.int8)
    padded[: cells.shape[0], : cells.shape[1]] = cells
    blocks = padded.reshape(rows // factor, factor, cols // factor, factor)
    out = np.full((rows // factor, cols // factor), UNKNOWN, dtype=np.int8)
    out[free_mask(blocks).any(axis=(1, 3))] = FREE
    out[occupied_mask(blocks).any(axis=(1, 3))] = OCCUPIED
    return out


def crop_observed(cells: NDArray[np.int8], margin: int = CROP_MARGIN) -> NDArray[np.int8]:
    """The bounding box of the observed cells, with ``margin`` cells around it."""
    rows, cols = np.nonzero(cells >= 0)
    r0, c0 = max(int(rows.min()) - margin, 0), max(int(cols.min()) - margin, 0)
    return cells[r0 : int(rows.max()) + margin + 1, c0 : int(cols.max()) + margin + 1]


def halmstad_cases(floor: str, sessions: int, scale: int, seed: int) -> list[Case]:
    """All pairs of the first ``sessions`` sessions of ``floor``, map 2 randomly posed."""
    folder = shared_maps() / "halmstad"
    maps = [
        coarsen_grid(crop_observed(merging.load_map(folder / f"{floor}_{n:02d}.yaml").data), scale)
        for n in range(1, sessions + 1)
    ]
    resolution = MAP_RESOLUTION * scale
    tolerance = Tolerance(HALMSTAD_TOLERANCE_METRES / resolution, HALMSTAD_DEGREES, resolution)
    rng = np.random.default_rng(seed)
    cases = []
    for i in range(sessions):
        for j in range(i + 1, sessions):
            posed, _ = random_pose(maps[j], rng)
            label = f"{floor}_{j + 1:02d}->{floor}_{i + 1:02d}"
            cases.append(
                Case(f"Exp. halmstad {floor}", "Exp.", label, maps[i], posed, None, tolerance)
            )
    return cases
