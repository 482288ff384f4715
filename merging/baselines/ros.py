"""The ROS ``multirobot_map_merge`` pipeline with OpenCV: ``"ros_akaze"``, ``"ros_orb"``.

The map merger most ROS users meet (the ``map_merge`` node of m-explore,
its ``combine_grids`` library) estimates transforms between grids with
OpenCV's stitching pipeline. This module runs the same OpenCV calls with
the same settings, so that time and accuracy are compared with the real
thing, not with a look-alike:

1. Each grid is handed to OpenCV as it is in memory: the ``int8`` ROS cells
   read as ``uint8`` (free 0, occupied 100, unknown 255), one image per map.
2. Features: ``cv2.AKAZE_create()`` (the node's default,
   ``estimation_feature_type: akaze``) or ``cv2.ORB_create()``, computed by
   ``cv2.detail.computeImageFeatures2``.
3. Matching and transform: ``cv2.detail_AffineBestOf2NearestMatcher(False,
   False, 0.3, 6)``: nearest-neighbour matches with a ratio test, then
   ``estimateAffinePartial2D`` (a similarity: rotation, uniform scale,
   translation) by RANSAC, and the pair's confidence
   ``inliers / (8 + 0.3 * matches)`` (Brown and Lowe).
4. Acceptance: the node keeps a pair whose confidence reaches its
   ``estimation_confidence`` (default 1.0), through
   ``cv2.detail.leaveBiggestComponent``. Here ``accepted`` is exactly that
   rule, and ``confidence`` is the pair's confidence ``c`` mapped to
   ``c / (1 + c)`` (so that 0.5 is the node's threshold).

So, unlike the other baselines, acceptance is the pipeline's own, not the
shared verification: this is what a user of the node gets. The similarity
is returned as it is (its scale is not forced to 1).

OpenCV is an optional dependency: ``pip install "tomosim[opencv]"`` (or
``pip install opencv-python-headless``).

References
----------
J. Hörner, "Map-merging for multi-robot system", Bachelor's thesis, Charles
University in Prague, 2016 (the m-explore ``map_merge`` package). M. Brown
and D. G. Lowe, "Automatic panoramic image stitching using invariant
features", IJCV 74(1), 2007. P. F. Alcantarilla et al., "Fast explicit
diffusion for accelerated features in nonlinear scale spaces", BMVC 2013.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from numpy.typing import NDArray

from merging.api import register_method
from merging.baselines.common import check_no_options, refusal
from merging.result import Hypothesis, MergeResult

INSTALL = 'pip install "tomosim[opencv]"  (or: pip install opencv-python-headless)'
"""How to install the optional dependency these methods need."""
MATCH_CONFIDENCE = 0.3
"""``match_conf`` of ``AffineBestOf2NearestMatcher``, the node's default: the
nearest descriptor must be at most 0.7 times as far as the second nearest."""
MIN_MATCHES = 6
"""``num_matches_thresh1``, the node's default: fewer matches give no transform."""
ACCEPT_PAIR_CONFIDENCE = 1.0
"""The node's ``estimation_confidence`` default: pairs below it are not merged."""
FINDERS = ("akaze", "orb")
"""Feature types the node offers without the non-free OpenCV modules."""
MIN_IMAGE_SIDE = 2
"""Cells a side an image needs before OpenCV's feature pyramids are built: on a grid one
cell wide ORB fails an assertion in its resize and AKAZE corrupts the heap (the process
aborts), where a wider one yields no keypoints and a clean refusal."""


def _cv2() -> Any:
    """OpenCV, or an ImportError that names the install command."""
    try:
        import cv2
    except ImportError as error:
        raise ImportError(f"the ROS pipeline baselines need OpenCV: {INSTALL}") from error
    return cv2


def ros_merge(
    cells1: NDArray[np.int8],
    cells2: NDArray[np.int8],
    *,
    finder: str,
    rng: np.random.Generator,
) -> MergeResult:
    """Estimate map 2 -> map 1 as ``multirobot_map_merge`` does (see the module docstring).

    Parameters
    ----------
    finder : str
        ``"akaze"`` or ``"orb"``.
    rng : numpy.random.Generator
        Seeds OpenCV's random generator (RANSAC), so runs repeat.
    """
    if finder not in FINDERS:
        raise ValueError(f"unknown feature type {finder!r}; choose one of {FINDERS}")
    cv2 = _cv2()
    cv2.setRNGSeed(int(rng.integers(0, 2**31 - 1)))
    name = f"ros_{finder}"
    timings: dict[str, float] = {}
    narrowest = min(*cells1.shape, *cells2.shape)
    if narrowest < MIN_IMAGE_SIDE:
        shapes = f"{cells1.shape[0]} x {cells1.shape[1]} and {cells2.shape[0]} x {cells2.shape[1]}"
        return refusal(
            name,
            f"{name}: maps of {shapes} cells; OpenCV's features need images at least "
            f"{MIN_IMAGE_SIDE} cells a side",
            timings,
        )
    clock = time.perf_counter()
    detector = cv2.AKAZE_create() if finder == "akaze" else cv2.ORB_create()
    images = [np.ascontiguousarray(cells.view(np.uint8)) for cells in (cells1, cells2)]
    features = [cv2.detail.computeImageFeatures2(detector, image) for image in images]
    timings["features"] = time.perf_counter() - clock

    clock = time.perf_counter()
    counts = [len(f.keypoints) for f in features]
    if min(counts) < 2:
        # OpenCV's nearest-neighbour search needs two keypoints to compare.
        return refusal(name, f"{name}: {counts[0]} and {counts[1]} keypoints; too few", timings)
    matcher = cv2.detail_AffineBestOf2NearestMatcher(False, False, MATCH_CONFIDENCE, MIN_MATCHES)
    try:
        pairwise = matcher.apply2(features)
    except cv2.error as error:
        # The matcher asserts on degenerate feature sets; for a map that means no match.
        first_line = str(error).strip().splitlines()[-1]
        return refusal(name, f"{name}: OpenCV's matcher found no match ({first_line})", timings)
    matcher.collectGarbage()
    info = pairwise[1]  # image 0 (map 1) against image 1 (map 2)
    timings["match"] = time.perf_counter() - clock
    found = info.H is not None and np.asarray(info.H).size == 9 and info.confidence > 0
    if found:
        to_map2 = np.asarray(info.H, dtype=float).reshape(3, 3)
        found = bool(np.all(np.isfinite(to_map2))) and abs(np.linalg.det(to_map2[:2, :2])) > 1e-9
    if not found:
        return refusal(
            name,
            f"{name}: {counts[0]} and {counts[1]} keypoints, {len(info.matches)} matches; "
            "no transform found",
            timings,
        )
    # H takes map 1's image points to map 2's; image (x, y) are our (col, row) cells.
    matrix = np.linalg.inv(to_map2)
    pair_confidence = float(info.confidence)
    accepted = pair_confidence >= ACCEPT_PAIR_CONFIDENCE
    reason = ""
    if not accepted:
        reason = (
            f"{name}: pair confidence {pair_confidence:.2f} ({info.num_inliers} inliers of "
            f"{len(info.matches)} matches) below the node's {ACCEPT_PAIR_CONFIDENCE}"
        )
    return MergeResult(
        matrix=matrix,
        confidence=pair_confidence / (1.0 + pair_confidence),
        accepted=accepted,
        method=name,
        hypotheses=(Hypothesis(matrix, pair_confidence),),
        timings=timings,
        reason=reason,
    )


def _registered(finder: str):
    def method(
        cells1: NDArray[np.int8],
        cells2: NDArray[np.int8],
        *,
        rng: np.random.Generator,
        **options: Any,
    ) -> MergeResult:
        check_no_options(f"ros_{finder}", options)
        return ros_merge(cells1, cells2, finder=finder, rng=rng)

    method.__name__ = f"ros_{finder}_merge"
    method.__doc__ = f"``multirobot_map_merge`` with ``{finder}`` features; see :func:`ros_merge`."
    return method


for _finder in FINDERS:
    register_method(f"ros_{_finder}")(_registered(_finder))
