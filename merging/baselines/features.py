"""Local-feature matchers on the grid image: ``"sift"``, ``"orb"``, ``"harris"``, ``"shi_tomasi"``.

The paper compares its merger with SURF [24], Harris corners ("HCD") [25]
and minimum-eigenvalue corners ("MEV") [26]. SURF is patented and not in
scikit-image, so its place is taken by scikit-image's SIFT, the descriptor
SURF approximates; ORB is added as the binary descriptor the ROS
``multirobot_map_merge`` package uses. Every matcher runs the same pipeline:

1. Render each grid as a grey-level image (:func:`merging.baselines.common.render`:
   walls dark, free space light, unknown grey, blurred by one cell).
2. Detect keypoints and describe them:

   * ``sift``: scikit-image's SIFT (difference-of-Gaussians blobs, 128-D
     gradient histograms, oriented);
   * ``orb``: scikit-image's ORB (FAST corners, oriented BRIEF, 256 bits);
   * ``harris`` and ``shi_tomasi``: Harris' corner response and the
     minimum eigenvalue of the structure tensor, local maxima by
     :func:`skimage.feature.corner_peaks`, described by oriented, normalised
     image patches (:mod:`merging.baselines.patches`), since a corner
     detector alone gives no descriptor.

3. Match descriptors: mutual nearest neighbours that also pass Lowe's ratio
   test (:data:`MAX_RATIO`).
4. Fit a rigid transform to the matches with RANSAC (:func:`merging.baselines.ransac.ransac_rigid`).

The acceptance verdict comes from :func:`merging.baselines.common.verdict`.

References
----------
D. G. Lowe, "Distinctive image features from scale-invariant keypoints",
IJCV 60(2), 2004. E. Rublee et al., "ORB: an efficient alternative to SIFT
or SURF", ICCV 2011. C. Harris and M. Stephens, "A combined corner and edge
detector", Alvey Vision Conference 1988. J. Shi and C. Tomasi, "Good
features to track", CVPR 1994.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from merging.api import register_method
from merging.baselines.common import (
    UNKNOWN_GREY,
    check_no_options,
    check_positive,
    refusal,
    render,
    verdict,
)
from merging.baselines.patches import orientations, oriented_patches
from merging.baselines.ransac import ransac_rigid
from merging.result import MergeResult

if TYPE_CHECKING:
    from skimage.feature import ORB, SIFT

# scikit-image's feature module is imported where it is used, not above: with it (it
# brings scipy.stats) and scipy.signal (spectral.py), `import merging`, which registers
# these methods, took 1.1 s instead of 0.7 s in every program, though few run them.

MAX_KEYPOINTS = 500
"""Keypoints kept per map by ORB and the corner detectors (the strongest):
enough to cover a building's corners, few enough that matching stays fast.
SIFT keeps all it finds, as it ranks none (a few hundred on a window)."""
MAX_RATIO = 0.8
"""Lowe's ratio test: the nearest descriptor must be this much closer than the
second nearest, as in Lowe 2004."""
RANSAC_THRESHOLD = 3.0
"""Cells a match may lie from the fitted transform and count as an inlier:
keypoints on a re-rasterised, blurred map move by one to two cells."""
RANSAC_ITERATIONS = 2000
"""Most RANSAC samples: with a tenth of the matches right, 2000 two-point
samples find a clean one with probability 1 - 0.99^2000."""
MIN_INLIERS = 5
"""Smallest consensus trusted as a transform: three or four agreeing matches
out of hundreds occur by chance."""
SIFT_SCALES = 2
"""Scales per octave of SIFT's scale space: both maps have the same resolution,
so few scales are needed, and each costs a full-image blur."""
ORB_SCALES = 4
"""Pyramid levels of ORB (scikit-image's default is 8): both maps have the same
resolution, and each level costs a FAST and Harris pass."""
CORNER_SIGMA = 1.5
"""Cells of Gaussian integration window of the Harris / Shi-Tomasi structure tensor."""
CORNER_MIN_DISTANCE = 3
"""Cells between two reported corners at least (non-maximum suppression)."""
CORNER_THRESHOLD = 0.01
"""Corner responses below this fraction of the strongest are dropped."""
HARRIS_K = 0.05
"""Harris' sensitivity factor k (0.04-0.06 in Harris and Stephens)."""


@dataclass(frozen=True, slots=True)
class Features:
    """Keypoints of one map and their descriptors.

    Attributes
    ----------
    points : (N, 2) float ndarray
        ``(x, y) = (col, row)`` keypoint positions, in cells.
    descriptors : (N, D) ndarray
        Float descriptors, or booleans for binary ones.
    """

    points: NDArray[np.float64]
    descriptors: NDArray[Any]

    @property
    def binary(self) -> bool:
        """Whether the descriptors are bit strings (compared by Hamming distance)."""
        return self.descriptors.dtype == np.bool_


MIN_IMAGE_SIDE = 32
"""Images are padded (with the unknown grey, after the last row and column) to at
least this many cells a side: scikit-image's detectors need room for their
patches and SIFT's coarsest octave (12 pixels), and a map that small holds no
features anyway."""


def _padded(image: NDArray[np.float64]) -> NDArray[np.float64]:
    """``image`` grown to :data:`MIN_IMAGE_SIDE` a side if smaller; cells keep their place."""
    rows, cols = image.shape
    if rows >= MIN_IMAGE_SIDE and cols >= MIN_IMAGE_SIDE:
        return image
    out = np.full((max(rows, MIN_IMAGE_SIDE), max(cols, MIN_IMAGE_SIDE)), UNKNOWN_GREY)
    out[:rows, :cols] = image
    return out


def _from_rows_cols(keypoints: NDArray[Any]) -> NDArray[np.float64]:
    """scikit-image's ``(row, col)`` keypoints as ``(x, y)``."""
    return np.asarray(keypoints, dtype=float)[:, ::-1].copy()


def _no_features(binary: bool) -> Features:
    width = 256 if binary else 128
    dtype = np.bool_ if binary else np.float32
    return Features(np.zeros((0, 2)), np.zeros((0, width), dtype=dtype))


def _run_extractor(extractor: SIFT | ORB, image: NDArray[np.float64], binary: bool) -> Features:
    """Run a scikit-image extractor; an image without features gives no keypoints."""
    try:
        extractor.detect_and_extract(image)
    except RuntimeError as error:
        # scikit-image raises this for images without contrast; for a map it
        # means no features, not a failure.
        if "no features" not in str(error):
            raise
        return _no_features(binary)
    points = _from_rows_cols(np.asarray(extractor.keypoints))
    descriptors = np.asarray(extractor.descriptors)
    if not binary:
        descriptors = descriptors.astype(np.float32)
    return Features(points, descriptors)


def sift_features(image: NDArray[np.float64]) -> Features:
    """SIFT keypoints and 128-D descriptors of a map image (no up-sampling)."""
    from skimage.feature import SIFT

    return _run_extractor(SIFT(upsampling=1, n_scales=SIFT_SCALES), image, binary=False)


def orb_features(image: NDArray[np.float64]) -> Features:
    """ORB keypoints and 256-bit descriptors of a map image."""
    from skimage.feature import ORB

    return _run_extractor(ORB(n_keypoints=MAX_KEYPOINTS, n_scales=ORB_SCALES), image, binary=True)


def _corner_features(response: NDArray[np.float64], image: NDArray[np.float64]) -> Features:
    from skimage.feature import corner_peaks

    peaks = corner_peaks(
        response,
        min_distance=CORNER_MIN_DISTANCE,
        threshold_rel=CORNER_THRESHOLD,
        num_peaks=MAX_KEYPOINTS,
    )
    if len(peaks) == 0:
        return Features(np.zeros((0, 2)), np.zeros((0, 1)))
    corners = _from_rows_cols(peaks)
    index, angles = orientations(image, corners)
    # A corner with several orientations becomes several keypoints at one place.
    points = corners[index]
    return Features(points, oriented_patches(image, points, angles))


def harris_features(image: NDArray[np.float64]) -> Features:
    """Harris corners ("HCD"), described by oriented patches."""
    from skimage.feature import corner_harris

    response = corner_harris(image, method="k", k=HARRIS_K, sigma=CORNER_SIGMA)
    return _corner_features(response, image)


def shi_tomasi_features(image: NDArray[np.float64]) -> Features:
    """Minimum-eigenvalue corners of Shi and Tomasi ("MEV"), described by oriented patches."""
    from skimage.feature import corner_shi_tomasi

    return _corner_features(corner_shi_tomasi(image, sigma=CORNER_SIGMA), image)


DETECTORS: dict[str, Callable[[NDArray[np.float64]], Features]] = {
    "sift": sift_features,
    "orb": orb_features,
    "harris": harris_features,
    "shi_tomasi": shi_tomasi_features,
}
"""Feature extractor of each registered matcher."""


def match(first: Features, second: Features) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """Indices ``(i1, i2)`` of mutual nearest-neighbour descriptors passing the ratio test."""
    from skimage.feature import match_descriptors

    if len(first.points) < 2 or len(second.points) < 2:
        empty = np.zeros(0, dtype=np.intp)
        return empty, empty
    metric = "hamming" if first.binary else "euclidean"
    pairs = match_descriptors(
        first.descriptors, second.descriptors, metric=metric, cross_check=True, max_ratio=MAX_RATIO
    )
    return pairs[:, 0].astype(np.intp), pairs[:, 1].astype(np.intp)


def feature_merge(
    cells1: NDArray[np.int8],
    cells2: NDArray[np.int8],
    *,
    detector: str,
    rng: np.random.Generator,
    threshold: float = RANSAC_THRESHOLD,
    iterations: int = RANSAC_ITERATIONS,
) -> MergeResult:
    """Match ``detector`` features of the two map images and fit a rigid transform.

    Parameters
    ----------
    detector : str
        One of :data:`DETECTORS`.
    rng : numpy.random.Generator
        Randomness of the RANSAC samples.
    threshold : float
        RANSAC inlier distance, in cells.
    iterations : int
        Most RANSAC samples.
    """
    if detector not in DETECTORS:
        raise ValueError(f"unknown detector {detector!r}; choose one of {sorted(DETECTORS)}")
    check_positive("threshold", threshold)
    check_positive("iterations", iterations, integer=True)
    timings: dict[str, float] = {}
    clock = time.perf_counter()
    extract = DETECTORS[detector]
    first = extract(_padded(render(cells1)))
    second = extract(_padded(render(cells2)))
    timings["features"] = time.perf_counter() - clock

    clock = time.perf_counter()
    index1, index2 = match(first, second)
    timings["match"] = time.perf_counter() - clock

    clock = time.perf_counter()
    fit = ransac_rigid(
        second.points[index2],
        first.points[index1],
        threshold=threshold,
        rng=rng,
        max_iterations=int(iterations),
        min_inliers=MIN_INLIERS,
    )
    timings["ransac"] = time.perf_counter() - clock
    if fit is None:
        return refusal(
            detector,
            f"{detector}: {len(first.points)} and {len(second.points)} keypoints, "
            f"{len(index1)} matches, fewer than {MIN_INLIERS} agreeing on a rigid transform",
            timings,
        )
    return verdict(cells1, cells2, fit.matrix, method=detector, timings=timings, score=fit.count)


def _registered(detector: str) -> Callable[..., MergeResult]:
    """The registry entry of one matcher: the common signature around :func:`feature_merge`."""

    def method(
        cells1: NDArray[np.int8],
        cells2: NDArray[np.int8],
        *,
        rng: np.random.Generator,
        threshold: float = RANSAC_THRESHOLD,
        iterations: int = RANSAC_ITERATIONS,
        **options: Any,
    ) -> MergeResult:
        check_no_options(detector, options)
        return feature_merge(
            cells1, cells2, detector=detector, rng=rng, threshold=threshold, iterations=iterations
        )

    method.__name__ = f"{detector}_merge"
    method.__doc__ = f"Feature matching with ``{detector}`` keypoints; see :func:`feature_merge`."
    return method


for _name in DETECTORS:
    register_method(_name)(_registered(_name))
