"""Whether the default method vouches for its best placement, and in words why not.

Two ways to vouch, either is enough (the confidence is the larger):

* the **close fit** of :func:`merging.evidence.verify.confidence`: the walls line up
  within a cell, there is enough of them, no different placement explains
  nearly as much, they pin the transform down and both maps saw common open
  space. Window pairs of one map and a robot's growing maps pass this way;
* the **robust evidence** of :func:`merging.evidence.robust.robust_confidence`: for
  maps of separate sessions, which bend and draw thick walls, a large
  overlap whose walls meet within a few cells, whose open space lies on open
  space, and which no placement farther than the maps bend comes near.

A placement either way would vouch for is then held against map 2's mirror
image (:mod:`merging.evidence.mirror`): if the mirrored map, laid on the same
overlap, explains nearly as much, the shared part looks the same in a mirror
and the placement cannot be told from the mirror twin of that part in a
mirror-symmetric building, so it is refused. The mirrored map is searched
for only then, since the search costs as much as the first. The mirror
check is a test of evidence already vouched for, not one more measure of
the fit: each way's confidence is at most the mirror factor, and a clear
pass leaves it as it was (a product would dent a placement vouched for
narrowly, even where its mirror image explains under half as much, and
refuse it in the mirror's name).

A refused result says why in words (:func:`refusal_reason`): too little
overlap, ambiguous between two placements a given distance apart or with the
mirror image, only one wall or corridor to align on, walls that do not meet,
or walls without shared open space. The numbers behind it are in
``MergeResult.evidence``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from functools import partial

import numpy as np
from numpy.typing import NDArray

from merging.evidence.mirror import MirrorCandidates, landing_cells, mirror_share
from merging.evidence.pinning import lever_arm, pinning
from merging.evidence.refine import SmoothedMap, constraint_strength, turning_strength
from merging.evidence.robust import (
    open_cells,
    open_consistency,
    robust_confidence,
    robust_factors,
    tolerant_fit,
)
from merging.evidence.verify import (
    PreparedMap,
    Verification,
    confidence_factors,
    dilate,
    pinned_factors,
    verify,
)
from merging.params import ConfidenceParams, TomographicParams
from merging.transforms import apply_transform, matrix_to_pose, wrap_angle

CLOSE_FACTORS = ("fit", "support", "distinct", "constraint", "space")
"""Names of the five factors of :func:`merging.evidence.verify.confidence`, in its order."""

MirrorSearch = Callable[[], MirrorCandidates]
"""Finds the placements of map 2's overlap part, mirrored, on map 1's (for the placement
being judged); called at most once, when needed."""

MIRROR_REASON = (
    "ambiguous: map 2 seen in a mirror fits map 1 about as well; what the maps share "
    "looks the same in a mirror, so it may be either of two mirror-image parts of the "
    "building"
)
"""Why a placement is refused when its evidence is as good for map 2's mirror image."""

LEVER_REASON = (
    "too little overlap for the extent of map 2: a turn too small to see where the maps "
    "meet would move map 2's far walls by more than the accuracy asked"
)
"""Why a close fit is refused when map 2's walls reach too far from the overlap
(``ConfidenceParams.max_lever``)."""


@dataclass(frozen=True, slots=True)
class Verdict:
    """The confidence in a placement, whether it is accepted, and why not.

    Attributes
    ----------
    confidence : float
        In ``[0, 1]``: the larger of the close-fit and the robust confidence.
    accepted : bool
        ``confidence >= ConfidenceParams.accept``.
    reason : str
        Empty when accepted; otherwise one sentence saying why not.
    evidence : dict
        The measures and factors behind the verdict (see
        :attr:`merging.result.MergeResult.evidence`).
    bent : bool
        Whether the maps bend against each other where they overlap: the
        robust evidence (a large overlap whose walls meet within a few
        cells) vouches for the placement, and more than the close fit does.
    loose : bool
        Whether the close fit vouches for a placement its curvature holds
        loosely: the constraint factor of the curvature alone is below
        ``ConfidenceParams.pin_below`` (the other factors carried it, or
        sliding and turning were shown to cost, :func:`turn_is_held`). Where
        the overlap holds a placement that loosely, the rasterised walls may
        pull it a cell or two aside; the default method checks it by
        refining the other way round.
    """

    confidence: float
    accepted: bool
    reason: str
    evidence: dict[str, float]
    bent: bool = False
    loose: bool = False


def judge(
    first: PreparedMap,
    second: PreparedMap,
    smoothed: SmoothedMap,
    best: NDArray[np.float64],
    runner_up: tuple[Verification, NDArray[np.float64]] | None,
    params: TomographicParams,
    mirror: MirrorSearch | None = None,
    *,
    far_runner_up: tuple[Verification, NDArray[np.float64]] | None = None,
    turn_returns: Callable[[], float] | None = None,
    slide_returns: Callable[[float], float] | None = None,
) -> Verdict:
    """Judge ``best`` (map 2 cells -> map 1 cells) against the best different placement.

    ``runner_up`` is that placement and its verification, or None when the
    search found no different one (or did not search): one farther than
    ``TomographicParams.distinct_cells``. The robust evidence, for maps that
    bend, holds ``best`` against ``far_runner_up`` instead, the best one
    farther than ``RobustParams.distinct_cells`` (None: there is none).
    ``mirror``, when
    given, finds map 2's mirrored placements; it is called only when a way
    of vouching passes, and then that way must also beat the mirror image:
    each by ``ConfidenceParams.mirror_margin`` of its evidence in its
    overlap (:func:`merging.evidence.mirror.mirror_share`), counted as that way
    counts it: the close fit at the tolerance it used, conflicts weighing
    against; the robust evidence as walls met within its tolerance. That
    way's confidence is then the smaller of its own and the mirror factor.
    ``turn_returns``, when given, says how far (cells RMS over map 2's
    walls) the narrow refinement ends from ``best`` when restarted from
    ``best`` turned a little about the overlap; it is called only for a
    placement held against sliding that only a weak turn keeps from being
    vouched for, and within ``ConfidenceParams.turn_return_cells`` the turn
    counts as held (:func:`turn_is_held`). ``slide_returns`` is asked the
    same for a placement whose turn is held (by its curvature or so) that
    only a slide costing too little keeps from being vouched for, restarted
    from each small slide :func:`merging.evidence.pinning.pinning` tries; it
    may stop at the first restart ending farther than the distance it is
    given (:func:`slide_is_held`).
    """
    check = verify(first, second, best, params=params.verify)
    strength = constraint_strength(smoothed, second, best, local=True, params=params.gauss_newton)
    other = None if runner_up is None else runner_up[0]
    fit_quality = check.quality
    fit_tolerance: int | None = None
    factors = confidence_factors(check, other, strength=strength, params=params.confidence)
    curvature = factors[3]
    if (
        np.prod(factors) < params.confidence.accept
        and check.agreeing >= params.confidence.tolerant_support
    ):
        # Two independently drawn maps of one building: walls a few cells apart.
        _, tolerant_quality = tolerant_fit(
            first, second, best, tolerance=params.confidence.fit_tolerance, params=params.verify
        )
        if tolerant_quality > fit_quality:
            fit_quality, fit_tolerance = tolerant_quality, params.confidence.fit_tolerance
        factors = confidence_factors(
            check, other, strength=strength, params=params.confidence, fit_quality=fit_quality
        )
    pinned: tuple[float, float] | None = None
    returned: dict[str, float] = {}
    # Sliding and turning bear on the constraint factor alone: measure them only when
    # the other factors leave the placement a chance.
    unconstrained = float(np.prod(factors)) / max(factors[3], 1e-12)
    if (
        np.prod(factors) < params.confidence.accept
        and factors[3] < params.confidence.pin_below
        and unconstrained >= params.confidence.accept
    ):
        # A weak curvature: see what sliding the placement a little would cost,
        # and how firmly its turn alone is held.
        slide = pinning(first, second, best, params=params.confidence, verify_params=params.verify)
        turn = turning_strength(smoothed, second, best, local=True, params=params.gauss_newton)
        pinned = (slide, turn)
        # The curvature's factors again, with sliding and turning: the turn as its
        # strength holds it, or, when the refinement comes back to it, as held.
        rate = partial(
            confidence_factors,
            check,
            other,
            strength=strength,
            params=params.confidence,
            fit_quality=fit_quality,
            pinned=pinned,
        )
        factors = rate()
        turn_held = turn_returns is not None and turn_is_held(
            factors,
            unconstrained,
            pinned,
            turn_returns,
            params.confidence,
            returned,
            fit_quality=fit_quality,
            slide_asked=slide_returns is not None,
        )
        if turn_held:
            factors = rate(turn_held=True)
        if slide_returns is not None and slide_is_held(
            factors,
            unconstrained,
            pinned,
            slide_returns,
            params.confidence,
            returned,
            fit_quality=fit_quality,
            turn_held=turn_held,
        ):
            factors = rate(turn_held=turn_held, slide_held=True)
    close = float(np.prod(factors))
    twins = _Twins(mirror)
    evidence: dict[str, float] = {
        "agreement": check.agreement,
        "conflict": check.conflict,
        "quality": check.quality,
        "fit_quality": fit_quality,
        "matching_wall_cells": check.agreeing,
        "shared_open_cells": check.shared_space,
        "strength": strength,
        "close_confidence": close,
    }
    if pinned is not None:
        evidence["slide_cost_cells"], evidence["turning_strength"] = pinned
    evidence.update(returned)
    evidence.update(
        {f"close_{name}": value for name, value in zip(CLOSE_FACTORS, factors, strict=True)}
    )
    for prefix, competitor in (("", runner_up), ("tolerant_", far_runner_up)):
        if competitor is not None:
            evidence[f"{prefix}margin"] = check.score - competitor[0].score
            evidence[f"{prefix}runner_up_distance_cells"] = _rms_between(
                best, competitor[1], second.points
            )
            turn = matrix_to_pose(best)[2] - matrix_to_pose(competitor[1])[2]
            evidence[f"{prefix}runner_up_turn_deg"] = float(np.degrees(abs(wrap_angle(turn))))
    accept = params.confidence.accept
    overreach = False
    if close >= accept:
        # A close fit holds map 2's far walls only as well as the overlap pins its turn.
        lever = lever_arm(first, second, best)
        evidence["lever_arm"] = lever
        if lever > params.confidence.max_lever:
            overreach = True
            close = 0.0
            evidence["close_confidence"] = close
    vouched = close >= accept
    if close >= accept and twins.available:
        share = mirror_share(
            first, second, best, twins.found(), tolerance=fit_tolerance, params=params.verify
        )
        chiral = _mirror_factor(share, params)
        evidence.update({"mirror_share": share, "close_mirror": chiral})
        # A test of the vouched evidence, not a sixth factor of its fit (module docstring).
        close = min(close, chiral)
        evidence["close_confidence"] = close
    robust = 0.0
    robust_scores: dict[str, float] = {}
    if close < accept:
        bounded, robust_scores = _robust(
            first, second, smoothed, best, check, evidence, params, at_most=close
        )
        robust = 0.0 if bounded is None else bounded
        vouched = vouched or robust >= accept
        if robust >= accept and twins.available:
            share = mirror_share(
                first,
                second,
                best,
                twins.found(),
                tolerance=params.robust.tolerance,
                conflict_weight=0.0,
                params=params.verify,
            )
            evidence["tolerant_mirror_share"] = share
            robust_scores["mirror"] = _mirror_factor(share, params)
            robust = min(robust, robust_scores["mirror"])
        if bounded is not None:
            evidence["robust_confidence"] = robust
        evidence.update({f"robust_{name}": value for name, value in robust_scores.items()})
    value = max(close, robust)
    accepted = value >= accept
    if accepted:
        reason = ""
    elif overreach:
        reason = LEVER_REASON
    elif vouched:
        # Either way vouched until held against the mirror image: that is why.
        reason = MIRROR_REASON
    else:
        if runner_up is not None:
            evidence["runner_up_same_walls"] = same_walls(
                first, second, best, runner_up[1], radius=params.verify.near_radius
            )
        reason = refusal_reason(factors, robust_scores, evidence)
    bent = robust >= accept and robust > close
    loose = accepted and not bent and close >= accept and curvature < params.confidence.pin_below
    return Verdict(value, accepted, reason, evidence, bent, loose)


def turn_is_held(
    factors: tuple[float, ...],
    unconstrained: float,
    pinned: tuple[float, float],
    turn_returns: Callable[[], float],
    params: ConfidenceParams,
    measures: dict[str, float],
    *,
    fit_quality: float,
    slide_asked: bool = False,
) -> bool:
    """Whether the refinement holds a placement's turn that its curvature holds weakly.

    A small overlap turns about itself: the curvature of the narrow fields
    (``turning_strength``) is flat there, though the placement may be the
    truth to a tenth of a cell. The refinement is asked instead: restarted
    from the placement turned by the accuracy a merge is asked for and
    twice that, either way, does it come back (``turn_returns()``, the
    farthest end, within ``params.turn_return_cells``)? Asked only when it
    can change the verdict: the factors (the close fit's five, with
    ``pinned``, the ``(slide, turn)`` of :func:`merging.evidence.verify.confidence_factors`)
    fall short of ``params.accept``, the turn is what holds the constraint
    back, with the slide's factor alone they would pass (``unconstrained``
    is their product without the constraint), and the walls meet closely
    (``fit_quality``, as the fit factor counts it, at least
    ``params.return_fit``): that the refinement comes back says its
    optimum is sharp, which vouches for the truth only where nearly every
    wall meets its twin. Adds the farthest end, as ``turn_return_cells``,
    to ``measures`` when asked.
    """
    slid, turned = pinned_factors(pinned, params)
    if (
        np.prod(factors) >= params.accept
        or unconstrained * turned >= params.accept
        or unconstrained * (1.0 if slide_asked else slid) < params.accept
        or fit_quality < params.return_fit
    ):
        return False
    returned = turn_returns()
    measures["turn_return_cells"] = returned
    return returned <= params.turn_return_cells


def slide_is_held(
    factors: tuple[float, ...],
    unconstrained: float,
    pinned: tuple[float, float],
    slide_returns: Callable[[float], float],
    params: ConfidenceParams,
    measures: dict[str, float],
    *,
    fit_quality: float,
    turn_held: bool = False,
) -> bool:
    """Whether the refinement holds a placement against sliding that costs too little.

    :func:`merging.evidence.pinning.pinning` counts the walls a small slide
    takes off their twins; a door or a short cross wall holding a corridor
    loses only tens of cells, which the slide's factor counts as weak,
    though the placement may be the truth to a tenth of a cell. As for the
    turn (:func:`turn_is_held`) the refinement is asked instead: restarted
    from the placement slid by each of those moves, does it come back
    (``slide_returns(within)``, the farthest end, within
    ``params.slide_return_cells``; it may stop at the first farther)? A
    restart that settles where the maps explain ``params.slide_settled_share``
    less, but more than they contradict, fell into a worse optimum and counts
    as back. A corridor with nothing across it does not come back: the narrow
    fields are flat along it, and the restarts lose nothing. Asked only when
    it can change the verdict: the factors fall short of ``params.accept``,
    the slide is what holds the constraint back (the turn held, by its own
    factor or by :func:`turn_is_held`: ``turn_held``), and the walls meet
    closely (``fit_quality`` at least ``params.return_fit``). Adds the
    farthest end, as ``slide_return_cells``, to ``measures`` when asked.
    """
    slid, turned = pinned_factors(pinned, params)
    turned = 1.0 if turn_held else turned
    if (
        np.prod(factors) >= params.accept
        or slid >= turned
        or unconstrained * turned < params.accept
        or fit_quality < params.return_fit
    ):
        return False
    returned = slide_returns(params.slide_return_cells)
    measures["slide_return_cells"] = returned
    return returned <= params.slide_return_cells


class _Twins:
    """Map 2's mirrored placements, searched for at most once and only when asked."""

    __slots__ = ("_found", "_search")

    def __init__(self, search: MirrorSearch | None):
        self._search = search
        self._found: MirrorCandidates | None = None

    @property
    def available(self) -> bool:
        return self._search is not None

    def found(self) -> MirrorCandidates:
        if self._found is None:
            assert self._search is not None
            self._found = self._search()
        return self._found


def _mirror_factor(share: float, params: TomographicParams) -> float:
    """One half when the evidence map 2's mirror image leaves unexplained is the margin.

    The logistic of ``1 - share`` centred at ``ConfidenceParams.mirror_margin``,
    as wide as the distinctiveness factor's.
    """
    confidence = params.confidence
    value = (1.0 - share) - confidence.mirror_margin
    return float(1.0 / (1.0 + np.exp(-value / confidence.distinct_width)))


def _robust(
    first: PreparedMap,
    second: PreparedMap,
    smoothed: SmoothedMap,
    best: NDArray[np.float64],
    check: Verification,
    evidence: dict[str, float],
    params: TomographicParams,
    *,
    at_most: float,
) -> tuple[float | None, dict[str, float]]:
    """The robust confidence of ``best`` and its factors; adds its measures to ``evidence``.

    The confidence is the weakest factor, so when one of the three that cost
    nothing (the margin, the agreeing walls, the shared open space) is
    already at most ``at_most`` (the close fit's confidence), the robust way
    can neither vouch nor raise the confidence: the costly measures are left
    out and the confidence is None. The constraint strength is still
    measured when the margin passes, as the refusal's reason may rest on it
    (:func:`refusal_reason`).
    """
    robust = params.robust
    smaller = min(open_cells(first), open_cells(second))
    measures = {
        # With no different placement at all, nothing competes: the margin passes.
        "margin": evidence.get("tolerant_margin", robust.margin + 1.0),
        "agreeing": check.agreeing,
        "open_share": check.shared_space / (2.0 * smaller) if smaller > 0 else 0.0,
    }
    cheap = robust_factors(measures, robust)
    settled = min(cheap.values()) <= at_most
    if not settled or cheap["margin"] >= 0.5:
        strength = evidence["strength"]
        for width in robust.strength_widths:
            wider = replace(params.gauss_newton, curvature_sigma=width, curvature_step=width)
            wide = constraint_strength(smoothed, second, best, local=True, params=wider)
            strength = max(strength, wide * width**2)
        measures["strength"] = strength
    if not settled:
        agreement, quality = tolerant_fit(
            first, second, best, tolerance=robust.tolerance, params=params.verify
        )
        measures.update(
            agreement=agreement,
            quality=quality,
            open_consistency=open_consistency(first, second, best),
        )
    evidence.update({f"tolerant_{k}": v for k, v in measures.items() if k != "margin"})
    if settled:
        return None, robust_factors(measures, robust)
    return robust_confidence(measures, robust)


REASON_ORDER = ("fit", "support", "constraint", "distinct", "space")
"""The close-fit factors in the order a refusal names them when several fail."""
SAME_WALLS = 0.5
"""Share of map 2's walls that the runner-up lays where the placement lays them (within
``near_radius``), below which the runner-up is another place rather than the same walls
laid again (:func:`refusal_reason`)."""


def same_walls(
    first: PreparedMap,
    second: PreparedMap,
    best: NDArray[np.float64],
    rival: NDArray[np.float64],
    *,
    radius: int,
) -> float:
    """Share of the walls ``best`` aligns that ``rival`` lays on the same walls again.

    Of map 2's wall points that ``best`` (map 2 cells -> map 1 cells) lays on
    map 1's walls (its agreeing points), the share that ``rival`` lays within
    ``radius`` cells (chessboard) of where ``best`` lays one of them: near 1
    when the rival slides the aligned walls along themselves or turns them
    end for end onto themselves, near 0 when it lays them elsewhere.
    """
    rows, cols = landing_cells(apply_transform(best, second.points), first.shape)
    agreeing = first.near_occupied[rows, cols]
    if not np.any(agreeing):
        return 0.0
    rows, cols = rows[agreeing], cols[agreeing]
    placed = np.zeros(first.shape, dtype=np.bool_)
    placed[rows, cols] = True
    # Where the rival lays the same points: rival after best's inverse, from their cells.
    aligned = np.column_stack([cols, rows]).astype(np.float64)
    moved = apply_transform(rival @ np.linalg.inv(best), aligned)
    rows, cols = landing_cells(moved, first.shape)
    return float(np.count_nonzero(dilate(placed, radius)[rows, cols])) / len(aligned)


def refusal_reason(
    close: tuple[float, ...], robust: dict[str, float], evidence: dict[str, float]
) -> str:
    """One sentence saying why a placement is not vouched for.

    The first failing factor of the close fit, in :data:`REASON_ORDER`,
    names the cause. When that is the fit itself (the walls do not meet
    within a cell or so) and the robust way was tried too, its failing
    factors refine it. Too few walls meeting within its tolerance comes
    first (a rival placement is no news for a placement that explains
    little: two maps of different buildings have many such); then a rival
    placement about as good means ambiguity, a weak constraint a single
    wall or corridor, or, when the refinement was restarted turned a little
    (``turn_return_cells`` in ``evidence``) and did not come back, an overlap
    too short to hold the turn (:func:`turn_reason`), or, restarted slid a
    little (``slide_return_cells``), a corridor it slides along
    (:func:`slide_reason`). A weak constraint gives way to a failing
    distinctiveness when neither restart was tried and the rival lays
    map 2's walls elsewhere (``runner_up_same_walls`` below
    :data:`SAME_WALLS`, :func:`same_walls`): along one straight wall the rival
    is the wall laid on itself the other way, and the slide is the news; a
    rival off those walls is another place the maps may show.
    """
    values = dict(zip(CLOSE_FACTORS, close, strict=True))
    failing = [name for name in REASON_ORDER if values[name] < 0.5]
    cause = failing[0] if failing else min(values, key=lambda name: values[name])
    restarted = "slide_return_cells" in evidence or "turn_return_cells" in evidence
    if (
        cause == "constraint"
        and "distinct" in failing
        and not restarted
        and evidence.get("runner_up_same_walls", 1.0) < SAME_WALLS
    ):
        # The rival lies elsewhere, not along the walls the placement aligns: no slide
        # was tried, and the rival refuses the placement whatever its slide would show.
        cause = "distinct"
    few_walls = little_space = False
    competitor = ""  # the close fit's runner-up; "tolerant_" for the robust way's
    if cause == "fit" and robust:
        weak = {name for name, value in robust.items() if value < 0.5}
        few_walls, little_space = "agreeing" in weak, "open_share" in weak
        if few_walls and values["support"] < 0.5:
            cause = "support"
        elif few_walls or little_space:
            cause = "fit"
        elif "margin" in weak:
            cause = "distinct"
        else:
            cause = "constraint" if "strength" in weak else "fit"
        competitor = "tolerant_"
    if cause == "distinct":
        return ambiguity_reason(
            evidence.get(f"{competitor}runner_up_distance_cells", 0.0),
            evidence.get(f"{competitor}runner_up_turn_deg", 0.0),
        )
    # The slide is asked about only once the turn is held, so it names the cause first.
    for measure, reason in (
        ("slide_return_cells", slide_reason),
        ("turn_return_cells", turn_reason),
    ):
        returned = evidence.get(measure, float("inf"))
        if cause == "constraint" and np.isfinite(returned):
            return reason(returned)
    if cause == "fit" and few_walls:
        return (
            "the walls do not line up: too few of them meet, even allowing a few cells for "
            "maps drawn in separate sessions"
        )
    if cause == "fit" and little_space:
        return (
            "the walls do not line up closely, and the maps share too little open space to "
            "vouch for maps drawn in separate sessions"
        )
    return {
        "fit": "the walls do not line up: too many of them land on the other map's open "
        "space (the maps disagree where they would overlap)",
        "support": "too little overlap: too few walls line up to be sure of the placement",
        "constraint": "only one wall or corridor to align on: the maps could slide along it",
        "space": "the maps share walls but no open space: they may show two neighbouring "
        "rooms side by side",
    }[cause]


def turn_reason(returned: float) -> str:
    """Why a placement held against sliding is refused for its turn: restarted turned a
    little about the overlap, the refinement ended ``returned`` cells (RMS) away."""
    return (
        "the overlap is too short to hold map 2's turn: started turned a little about "
        f"it, the fit settles {returned:.1f} cells away"
    )


def slide_reason(returned: float) -> str:
    """Why a placement whose slide costs little is refused: restarted slid a little, the
    refinement ended ``returned`` cells (RMS) away."""
    return (
        "only one wall or corridor to align on: started slid a little along it, the fit "
        f"settles {returned:.1f} cells away"
    )


def reverse_reason(gap: float, confidence: float, params: ConfidenceParams) -> str:
    """Why a placement is refused when refining map 1 onto map 2 instead lands ``gap``
    cells (RMS over map 2's walls) from it, leaving it ``confidence``."""
    if gap > params.reverse_gap_cells:
        return (
            "the overlap does not hold map 2 to the accuracy asked: refined the other way "
            f"round (map 1 onto map 2), the placement lands {gap:.1f} cells away"
        )
    return (
        f"only just short of sure (confidence {confidence:.3f}, {params.accept:g} asked): "
        f"refined the other way round (map 1 onto map 2), the placement lands {gap:.1f} "
        "cells away"
    )


def ambiguity_reason(distance: float, turn_deg: float) -> str:
    """Why a placement is refused when another, ``distance`` cells RMS away and turned by
    ``turn_deg`` degrees from it, explains about as much."""
    turn = round(turn_deg)
    turned = f", turned {turn} degree{'' if turn == 1 else 's'} from it" if turn >= 1 else ""
    return (
        "ambiguous: another placement about as good lies "
        f"{distance:.0f} cells away{turned}; the maps may show a repeated or "
        "symmetric part of the building"
    )


def _rms_between(
    a: NDArray[np.float64], b: NDArray[np.float64], points: NDArray[np.float64]
) -> float:
    """RMS distance, in cells, between where ``a`` and ``b`` put ``points``."""
    diff = apply_transform(a, points) - apply_transform(b, points)
    return float(np.sqrt(np.mean(np.sum(diff**2, axis=1))))
