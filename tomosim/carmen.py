"""Reading laser scans and poses from CARMEN log files (``.log`` or ``.log.gz``).

Only the old-style front-laser message is read::

    FLASER n r_1 ... r_n x y theta odom_x odom_y odom_theta ipc_timestamp host logger_timestamp

``r_i`` are ranges in metres, ``(x, y, theta)`` the robot pose (in the
``*-corrected`` logs, the corrected pose) and ``odom_*`` the raw odometry. The
message carries no angles: a front laser sweeps ``fov`` radians
(:data:`CARMEN_FOV`, 180 degrees) from right to left, and beam ``i`` of ``n``
points at ``-fov / 2 + i * fov / (n - 1)`` from the heading, both ends of the
field of view included (the lidar coding of :mod:`tomosim.lidar`).
"""

from __future__ import annotations

import gzip
import math
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from tomosim.lidar import LidarConfig, Scan

CARMEN_FOV = np.pi
"""Field of view of a CARMEN front laser, radians."""
CARMEN_MAX_RANGE = 50.0
"""Range (m) that the logs write for a beam with no return; returns at or beyond
it are treated as no return."""
FLASER_TRAILER = 9
"""Fields after the ranges of a FLASER line: pose (3), odometry (3), timestamp,
host, logger timestamp."""


@dataclass(frozen=True)
class CarmenLog:
    """The FLASER messages of one log.

    Attributes
    ----------
    ranges : (T, B) float ndarray
        Raw ranges in metres as logged.
    poses : (T, 3) float ndarray
        Robot poses ``(x, y, theta)`` (corrected in a corrected log).
    odometry : (T, 3) float ndarray
        Raw odometry poses.
    timestamps : (T,) float ndarray
        IPC timestamps, seconds.
    """

    ranges: NDArray[np.float64]
    poses: NDArray[np.float64]
    odometry: NDArray[np.float64]
    timestamps: NDArray[np.float64]

    def __len__(self) -> int:
        return len(self.ranges)

    def lidar_config(self) -> LidarConfig:
        """The noise-free :class:`~tomosim.lidar.LidarConfig` matching the log's laser."""
        return LidarConfig(
            beams=self.ranges.shape[1],
            fov=CARMEN_FOV,
            max_range=CARMEN_MAX_RANGE,
            range_noise_std=0.0,
            dropout_probability=0.0,
        )

    def scan(self, index: int, *, max_range: float = CARMEN_MAX_RANGE) -> Scan:
        """Message ``index`` as a :class:`~tomosim.lidar.Scan`.

        Returns at or beyond ``max_range`` become ``inf`` (no return);
        non-positive ones ``nan`` (no reading).
        """
        if not 0 <= index < len(self):
            raise IndexError(f"index {index} out of range for a log of {len(self)} scans")
        ranges = self.ranges[index].astype(float)
        ranges[ranges >= max_range] = np.inf
        ranges[ranges <= 0.0] = np.nan
        return Scan(self.lidar_config().angles(), ranges, max_range)


GZIP_MAGIC = b"\x1f\x8b"
"""The first two bytes of a gzip-compressed file."""


def read_carmen(path: str | Path) -> CarmenLog:
    """Read every FLASER message of a CARMEN log.

    Parameters
    ----------
    path : str or Path
        A ``.log`` file, or a gzip-compressed one (told by its first bytes,
        whatever its name).

    Returns
    -------
    CarmenLog

    Raises
    ------
    FileNotFoundError
        If the file does not exist.
    ValueError
        If a FLASER line is malformed (fewer than two beams, a field that is
        not a number, a pose that is not finite), scans differ in beam
        count, the log has no FLASER message, is not text, or is compressed
        and cut short (the message says how many scans were read before).
    """
    source = Path(path)
    if not source.is_file():
        raise FileNotFoundError(f"CARMEN log not found: {source}")
    with open(source, "rb") as head:
        compressed = head.read(2) == GZIP_MAGIC
    ranges: list[list[float]] = []
    poses: list[list[float]] = []
    odometry: list[list[float]] = []
    stamps: list[float] = []
    number = 0
    try:
        with gzip.open(source, "rt") if compressed else open(source) as lines:
            for number, line in enumerate(lines, start=1):
                fields = line.split()
                if not fields or fields[0] != "FLASER":
                    continue
                try:
                    count = int(fields[1])
                    if count < 2:
                        raise ValueError(f"{count} beams; a scan needs at least 2")
                    values = fields[2 : 2 + count]
                    trailer = fields[2 + count : 2 + count + FLASER_TRAILER]
                    if len(values) != count or len(trailer) != FLASER_TRAILER:
                        raise ValueError("too few fields")
                    pose = [float(v) for v in trailer[0:3]]
                    if not all(math.isfinite(v) for v in pose):
                        raise ValueError(f"pose {pose} is not finite")
                    ranges.append([float(v) for v in values])
                    poses.append(pose)
                    odometry.append([float(v) for v in trailer[3:6]])
                    stamps.append(float(trailer[6]))
                except (IndexError, ValueError) as exc:
                    raise ValueError(f"{source}:{number}: malformed FLASER line ({exc})") from exc
                if len(ranges[-1]) != len(ranges[0]):
                    raise ValueError(
                        f"{source}:{number}: {len(ranges[-1])} beams, but the first "
                        f"scan has {len(ranges[0])}"
                    )
    except EOFError as exc:
        raise ValueError(
            f"{source} is cut short: its compressed data ends after line {number} "
            f"({len(ranges)} scans read); `gzip -dc` recovers what is there ({exc})"
        ) from exc
    except (gzip.BadGzipFile, zlib.error) as exc:
        raise ValueError(
            f"{source} is corrupt: its compressed data cannot be read after line {number} "
            f"({len(ranges)} scans read; {exc})"
        ) from exc
    except UnicodeDecodeError as exc:
        raise ValueError(
            f"{source} is not a text CARMEN log (nor a gzip-compressed one): it holds "
            f"bytes that are not text after line {number}"
        ) from exc
    if not ranges:
        raise ValueError(f"{source} holds no FLASER message")
    return CarmenLog(np.array(ranges), np.array(poses), np.array(odometry), np.array(stamps))
