"""CARMEN logs: parsing, and mapping the ACES log reproduces the aces3 map."""

from __future__ import annotations

import gzip
from pathlib import Path

import numpy as np
import pytest
from scipy import ndimage, signal

from merging.evaluation.metrics import acceptance_index, matching_index
from merging.grid import OccupancyGrid
from merging.mapio import load_map
from tomosim.carmen import CARMEN_MAX_RANGE, read_carmen
from tomosim.data import datasets_dir, maps_dir
from tomosim.mapping import LogOddsMap, MappingConfig

ACES_ACCEPTANCE = 0.95
"""Least acceptance index of our map of the ACES log against aces3 once aligned
(0.984 measured; the reference was rasterised from the same corrected log)."""


WALL_MATCHING = 0.4
"""Least matching index (eq. 31 of the paper) of the aligned ACES maps."""


def aces_paths() -> tuple[Path, Path]:
    data, maps = datasets_dir(), maps_dir()
    if data is None or maps is None:
        pytest.skip("shared data not found (set TOMOSIM_SHARED or TOMOSIM_MAPS)")
    log = data / "carmen" / "aces-corrected.log.gz"
    reference = maps / "aces3.yaml"
    if not (log.is_file() and reference.is_file()):
        pytest.skip(f"{log} or {reference} is missing")
    return log, reference


def translation_by_correlation(fixed: OccupancyGrid, moving: OccupancyGrid) -> tuple[int, int]:
    """Cell shift ``(dx, dy)`` best laying ``moving``'s occupied cells on ``fixed``'s.

    FFT cross-correlation of the occupied masks, each grown by one cell so
    that walls rasterised a cell apart still overlap.
    """
    a = ndimage.binary_dilation(fixed.occupied()).astype(float)
    b = ndimage.binary_dilation(moving.occupied()).astype(float)
    correlation = signal.fftconvolve(a, b[::-1, ::-1], mode="full")
    row, col = np.unravel_index(int(np.argmax(correlation)), correlation.shape)
    return int(col - (b.shape[1] - 1)), int(row - (b.shape[0] - 1))


def shift_matrix(dx: float, dy: float) -> np.ndarray:
    return np.array([[1.0, 0.0, dx], [0.0, 1.0, dy], [0.0, 0.0, 1.0]])


def test_reader_parses_flaser_lines(tmp_path: Path) -> None:
    ranges = " ".join(["1.5"] * 4)
    text = (
        f"# comment\nODOM 0 0 0 0 0 0 1.0 host 1.0\n"
        f"FLASER 4 {ranges} 1.0 2.0 0.5 1.1 2.1 0.6 3.25 host 3.3\n"
        f"FLASER 4 1 2 3 {CARMEN_MAX_RANGE} -1.0 0.0 -0.5 0 0 0 4.0 host 4.1\n"
    )
    path = tmp_path / "tiny.log.gz"
    with gzip.open(path, "wt") as handle:
        handle.write(text)
    log = read_carmen(path)
    assert len(log) == 2
    np.testing.assert_allclose(log.poses, [[1.0, 2.0, 0.5], [-1.0, 0.0, -0.5]])
    np.testing.assert_allclose(log.odometry[0], [1.1, 2.1, 0.6])
    np.testing.assert_allclose(log.timestamps, [3.25, 4.0])
    scan = log.scan(1)
    np.testing.assert_allclose(scan.ranges[:3], [1.0, 2.0, 3.0])
    assert np.isinf(scan.ranges[3])
    # Four beams over 180 degrees, both ends included.
    np.testing.assert_allclose(scan.angles, np.radians([-90.0, -30.0, 30.0, 90.0]))


def test_reader_rejects_bad_files(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError):
        read_carmen(tmp_path / "missing.log")
    bad = tmp_path / "bad.log"
    bad.write_text("FLASER 3 1.0 2.0\n")
    with pytest.raises(ValueError, match=r"bad\.log:1"):
        read_carmen(bad)
    empty = tmp_path / "empty.log"
    empty.write_text("ODOM 0 0 0\n")
    with pytest.raises(ValueError, match="no FLASER"):
        read_carmen(empty)


LINE = "FLASER 4 1 2 3 4 1.0 2.0 0.5 1.1 2.1 0.6 3.25 host 3.3\n"


def test_reader_tells_compressed_logs_by_their_bytes_and_tabs_apart(tmp_path: Path) -> None:
    # A gzipped log without the .gz suffix failed on decoding; tabs hid every scan.
    renamed = tmp_path / "SCANS.LOG"
    renamed.write_bytes(gzip.compress((LINE * 3).encode()))
    assert len(read_carmen(renamed)) == 3
    tabbed = tmp_path / "tabbed.log"
    tabbed.write_text(LINE.replace(" ", "\t") * 2)
    assert len(read_carmen(tabbed)) == 2


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("FLASER 1 2.0 1.0 2.0 0.5 1.1 2.1 0.6 3.25 host 3.3\n", "at least 2"),
        (LINE.replace("1.0 2.0 0.5", "nan 2.0 0.5"), "not finite"),
    ],
)
def test_reader_refuses_scans_it_cannot_use(tmp_path: Path, text: str, match: str) -> None:
    path = tmp_path / "odd.log"
    path.write_text(LINE + text)
    with pytest.raises(ValueError, match=rf"odd\.log:2: malformed FLASER line \(.*{match}"):
        read_carmen(path)


def test_reader_names_a_compressed_log_cut_short(tmp_path: Path) -> None:
    whole = gzip.compress((LINE * 2000).encode())
    cut = tmp_path / "cut.log.gz"
    cut.write_bytes(whole[: len(whole) // 2])
    with pytest.raises(ValueError, match=r"cut\.log\.gz is cut short.*scans read"):
        read_carmen(cut)
    binary = tmp_path / "binary.log"
    binary.write_bytes(bytes(range(128, 256)))
    with pytest.raises(ValueError, match="is not a text CARMEN log"):
        read_carmen(binary)


@pytest.mark.slow
def test_mapping_the_aces_log_reproduces_aces3() -> None:
    log_path, reference_path = aces_paths()
    log = read_carmen(log_path)
    assert len(log) == 440 and log.ranges.shape[1] == 180
    # The reference carves no free space along beams without a return.
    grid_map = LogOddsMap(MappingConfig(carve_no_return=False))
    for index in range(len(log)):
        grid_map.update(log.poses[index], log.scan(index))
    ours = grid_map.to_occupancy_grid()
    reference = load_map(reference_path)
    dx, dy = translation_by_correlation(reference, ours)
    best = acceptance_index(reference.data, ours.data, shift_matrix(dx, dy))
    assert best > ACES_ACCEPTANCE
    # The search found the optimum: no neighbouring shift does better.
    for ddx in (-1, 0, 1):
        for ddy in (-1, 0, 1):
            neighbour = acceptance_index(
                reference.data, ours.data, shift_matrix(dx + ddx, dy + ddy)
            )
            assert neighbour <= best + 1e-12
    # The walls themselves coincide too (the paper's matching index, eq. 31):
    # 0.47 measured, 0.31 one cell off and 0.22 two cells off. The reference keeps more
    # wall cells (a cell once hit stays occupied there; here later beams
    # passing through it can free it again), which caps the index.
    assert matching_index(reference.data, ours.data, shift_matrix(dx, dy)) > WALL_MATCHING
    assert matching_index(reference.data, ours.data, shift_matrix(dx + 2, dy)) < WALL_MATCHING
    # And the found shift is a whole number of cells between the two origins.
    offset = (np.asarray(ours.origin[:2]) - np.asarray(reference.origin[:2])) / 0.05
    assert np.allclose(offset, np.rint(offset))


def test_reader_names_a_corrupt_compressed_log(tmp_path: Path) -> None:
    # A flipped bit in the compressed data escaped as a raw zlib.error.
    data = bytearray(gzip.compress((LINE * 2000).encode()))
    data[20] ^= 0x55  # the first bytes of the deflate stream
    corrupt = tmp_path / "corrupt.log.gz"
    corrupt.write_bytes(bytes(data))
    with pytest.raises(ValueError, match=r"corrupt\.log\.gz is corrupt"):
        read_carmen(corrupt)
