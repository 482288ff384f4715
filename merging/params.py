"""The settings of the default (``"tomographic"``) merger, in one frozen object, and of linking.

Every tuning constant of the default method lives here, grouped by the stage
that uses it, each with its unit and the reason for its value. Pass a changed
copy to :func:`merging.estimate_transform`::

    from dataclasses import replace
    from merging.params import TomographicParams

    params = TomographicParams()
    stricter = replace(params, confidence=replace(params.confidence, accept=0.7))
    merging.estimate_transform(map1, map2, params=stricter)

The stage objects are used on their own too: the verification
(:class:`VerifyParams`) and the confidence (:class:`ConfidenceParams`) are
shared by every method, so that ``accepted`` means the same for all of them.
How N grids are linked from their pairwise estimates, whatever the method, is
set by :class:`LinkingParams` (:func:`merging.link_maps`, ``params=``).

Each class checks its fields by their declared types when made
(:mod:`merging.validators`): a count must be a whole number, a threshold a
finite number, a fraction one in ``[0, 1]``.
"""

from __future__ import annotations

import typing
from dataclasses import dataclass, field, fields
from typing import Any

from merging.validators import SettingTypeError, boolean, real_number, whole_number

# The dataclasses below are frozen and slotted; their defaults are the values the
# benchmarks in scripts/ were run with.


_FIELD_TYPES: dict[type, tuple[tuple[str, Any], ...]] = {}
"""Per settings class, :func:`_field_types`' answer (resolving annotations takes a while)."""


def _field_types(kind: type) -> tuple[tuple[str, Any], ...]:
    """Each field of the settings class ``kind`` with its type, the annotation resolved."""
    if kind not in _FIELD_TYPES:
        hints = typing.get_type_hints(kind)
        _FIELD_TYPES[kind] = tuple((item.name, hints[item.name]) for item in fields(kind))
    return _FIELD_TYPES[kind]


def _check_fields(
    settings: Any, *, positive: tuple[str, ...] = (), fractions: tuple[str, ...] = ()
) -> None:
    """Raise naming the field unless every field of ``settings`` is of its declared type.

    Whole numbers (``int``, not bool) are at least 0, and at least 1 when
    ``positive`` names them; numbers (``float``) are finite, and above 0 when
    ``positive`` names them, within ``[0, 1]`` when ``fractions`` does; a
    tuple holds entries of its declared types (as many as it declares, unless
    it ends in ``...``), numbers checked as a ``float`` field is; a stage's
    settings are an instance of their class. Without it a value of the wrong
    kind fails deep inside the search, or a threshold above 1 refuses every
    match with a reason about the walls.
    """
    owner = type(settings).__name__
    for name, kind in _field_types(type(settings)):
        where = f"{owner}.{name}"
        value = getattr(settings, name)
        if typing.get_origin(kind) is tuple:
            entries = typing.get_args(kind)
            if not isinstance(value, tuple) or not value:
                one = "number" if entries[0] is float else entries[0].__name__
                raise SettingTypeError(
                    f"{where} must be a tuple of at least one {one}, got {value!r}"
                )
            if entries[-1] is not Ellipsis and len(value) != len(entries):
                raise ValueError(f"{where} must hold {len(entries)} entries, got {value!r}")
            for k, entry in enumerate(value):
                _check_value(entry, entries[0], f"{where}[{k}]", name, positive, fractions)
        else:
            _check_value(value, kind, where, name, positive, fractions)


def _check_value(
    value: object,
    kind: Any,
    where: str,
    name: str,
    positive: tuple[str, ...],
    fractions: tuple[str, ...],
) -> None:
    """One value of :func:`_check_fields` against its type ``kind``."""
    if kind is bool:
        boolean(value, where)
    elif kind is int:
        whole_number(value, where, minimum=1 if name in positive else 0)
    elif kind is float and name in fractions:
        real_number(value, where, low=0.0, high=1.0)
    elif kind is float and name in positive:
        real_number(value, where, low=0.0, low_open=True)
    elif kind is float:
        real_number(value, where)
    elif isinstance(kind, type) and not isinstance(value, kind):
        raise SettingTypeError(f"{where} must be a {kind.__name__}, got {type(value).__name__}")


@dataclass(frozen=True, slots=True)
class RotationParams:
    """Rotation hypotheses from angular spectra (:mod:`merging.tomographic.angular`).

    Attributes
    ----------
    angle_step_deg : float
        Degrees between samples of the angular spectra: the paper's sinograms
        use 1°; the peaks are refined to sub-degree afterwards.
    min_frequency : int
        Lowest radial frequency used, in FFT bins: below it the spectrum
        describes the map's overall extent, which differs between partial
        maps, not its walls.
    max_frequency_fraction : float
        Highest radial frequency used, as a fraction of Nyquist: above it the
        spectrum is rasterisation noise.
    peak_separation_deg : float
        Two rotation peaks closer than this (degrees) are one peak.
    peaks : int
        Rotation peaks (modulo 180°) kept; with their 180° twins, twice as
        many hypotheses. In every real-map window pair examined the true
        rotation was among the three strongest (rectilinear buildings put its
        90° neighbours next).
    """

    angle_step_deg: float = 1.0
    min_frequency: int = 3
    max_frequency_fraction: float = 0.75
    peak_separation_deg: float = 4.0
    peaks: int = 3

    def __post_init__(self) -> None:
        _check_fields(self, positive=("peaks",), fractions=("max_frequency_fraction",))
        # Two samples per half turn at least; below a hundredth of a degree the spectra
        # grow past memory without a finer answer (the peaks are refined afterwards).
        real_number(self.angle_step_deg, "RotationParams.angle_step_deg", low=0.01, high=90.0)


@dataclass(frozen=True, slots=True)
class TranslationParams:
    """Translation hypotheses from the pooled projection correlation.

    Used by :mod:`merging.tomographic.correlate`.

    Attributes
    ----------
    coarse_cells : int
        Largest side of the coarse grid, in blocks: bounds the FFT size (and
        the time) for any map.
    wall_blur : float
        Gaussian blur of map 1's walls, in coarse cells: a 1-2° rotation error
        moves far walls by about one coarse cell.
    free_penalty : float
        Weight of map 1's clear free space in the correlation target, relative
        to a wall: walls laid across open rooms lose.
    peak_suppression : int
        Coarse cells around a translation peak within which weaker peaks are
        dropped: they are the same answer.
    peaks : int
        Translations kept per rotation hypothesis.
    significant_peaks : int
        Further translations kept per rotation hypothesis, the strongest by
        significance rather than by collected mass (:mod:`merging.tomographic.correlate`):
        a shift laying much of map 2 loosely on map 1 collects more mass
        than one laying a small part exactly, so the true shift of maps that
        share 3-15 % of their area is rarely among the strongest by mass.
        Significance is the mass less ``reverse_penalty`` for each of map 1's
        wall blocks landing in map 2's clear free space, which the loose
        overlap pays for. They join the screening; the refinement's first
        admissions by correlation still take the strongest by mass, so maps
        that overlap much are searched as before. Six, the number chosen when
        significance was the mass over a power of map 2's wall blocks landing
        on map 1's observed blocks (the changelog): every further candidate
        is one more chance for a wrong placement.
    reverse_penalty : float
        What each of map 1's wall blocks landing on a block of map 2 that is
        clear free space throughout costs in a shift's significance, against
        a wall block collected (the other way round of ``free_penalty``: map
        2's lidar saw through that space). On 30 seeds of the low-overlap
        windows (``scripts/bench_real_maps.py low-overlap``, 9000 pairs: 2026,
        1717, 1818, 60606, 4242, 31415, 92653, 58979, 27182, 11111, 44444,
        77777, 88888, 99999, 12345, 54321, 101, 202, 303, 404, 7, 13, 19, 23,
        29, 37, 5150, 6161, 7272 and 8383) one accepted 4247 right, 14 wrong,
        where the mass over the square root of the landing walls accepted 4171
        right, 14 wrong.
    """

    coarse_cells: int = 160
    wall_blur: float = 0.7
    free_penalty: float = 0.5
    peak_suppression: int = 2
    peaks: int = 3
    significant_peaks: int = 6
    reverse_penalty: float = 1.0

    def __post_init__(self) -> None:
        _check_fields(self, positive=("coarse_cells", "peaks"))
        # A blur as wide as the coarse grid smears every wall over the whole map.
        real_number(
            self.wall_blur, "TranslationParams.wall_blur", low=0.0, high=self.coarse_cells,
            low_open=True, unit="blocks",
        )  # fmt: skip


@dataclass(frozen=True, slots=True)
class VerifyParams:
    """Carrying each map's walls into the other (:mod:`merging.evidence.verify`).

    Attributes
    ----------
    max_points : int
        Occupied cells per map used for verification; more add time, not
        evidence.
    max_open_points : int
        Clear free cells per map used to count shared open space: it is
        counted, not located, so fewer samples do (about 1 % precision).
    near_radius : int
        Cells (chessboard) within which a carried cell counts as landing on a
        wall: rasterising a rotated wall moves its cells by up to one cell.
    conflict_clearance : int
        A free cell is evidence against a wall only this many cells
        (chessboard) beyond ``near_radius`` from any occupied cell, so
        slightly offset walls are not punished.
    conflict_weight : float
        What a conflicting cell costs relative to what an agreeing one earns.
    overlap_preference : float
        Fit (quality) that a tenfold larger wall overlap is worth when
        ranking hypotheses.
    space_preference : float
        Fit (quality) that a tenfold larger shared open space (free cells
        landing on free cells) is worth when ranking hypotheses. Maps of
        separate sessions bend against each other and draw walls 2-3 cells
        thick, so a right placement lays 20-40 % of the walls beside the
        other map's and fits no better than a wrong one that lays a corner
        on a corner; but it lays open space on open space, hundreds of times
        more than the wrong one. Set on the even-numbered E5 session pairs
        and window pairs of four maps (any value from 1 to 2 ranks every
        window pair as 0.05 alone did), checked on the odd-numbered ones.
    ranking_tolerance : int
        When above 0, the ranking score (:attr:`merging.evidence.verify.Verification.score`)
        adds the quality with walls counted as met within this many cells
        (chessboard; conflicts only beyond it plus ``conflict_clearance``) to
        the quality within ``near_radius``: ray consistency that survives
        the bending between sessions. 0 ranks by the close quality alone.
    screen_stride : int
        Hypotheses are first screened with every ``screen_stride``-th
        verification point (about 1000 per map), enough to rank them; the
        refined ones are verified with all.
    """

    max_points: int = 4000
    max_open_points: int = 1500
    near_radius: int = 1
    conflict_clearance: int = 2
    conflict_weight: float = 3.0
    overlap_preference: float = 0.05
    space_preference: float = 1.5
    ranking_tolerance: int = 0
    screen_stride: int = 4

    def __post_init__(self) -> None:
        _check_fields(
            self, positive=("max_points", "max_open_points", "screen_stride"), fractions=()
        )


@dataclass(frozen=True, slots=True)
class ConfidenceParams:
    """The five factors of the confidence, the mirror check, the threshold.

    The factors are those of :func:`merging.evidence.verify.confidence`.

    The constants were set on 200 window pairs of four real maps and 144
    pairs of robots' maps from six simulated episodes, so that no merge more
    than 2 cells (windows) or 1 m (episodes) off reaches confidence 0.2,
    while nearly nine in ten right window merges are accepted;
    ``scripts/calibrate_confidence.py`` reruns that check on other seeds.

    Attributes
    ----------
    fit_centre : float
        Quality at which the fit factor is one half: right merges of real and
        simulated maps score 0.85-1; wrong ones that fit a repeated room,
        0.7-0.86.
    fit_width : float
        Width of the fit factor's logistic, in quality.
    fit_tolerance : int
        For the default method, the fit is the better of the quality above
        and the quality with walls counted as met within this many cells
        (chessboard; conflicts only beyond it plus the clearance): two maps
        of one building rasterised independently (two sources, two sessions)
        draw a wall up to a few cells apart. On 400 low-overlap window pairs
        of four maps (seeds 11 and 3) the highest confidence of a wrong
        placement rose from 0.35 to 0.43 with it, below the threshold; fresh
        seeds are checked by ``scripts/bench_real_maps.py low-overlap``.
    tolerant_support : float
        Agreeing wall cells (both directions) a placement needs before the
        tolerant fit counts: the wider the tolerance, the likelier walls meet
        by chance, so it needs more of them (about 100 m of wall at 0.05 m).
        Small robot maps early in an episode, which have a few hundred, are
        held to the one-cell fit: with the tolerant fit alone, one such pair
        of a simulated episode was accepted 24 m off.
    support_scale : float
        Agreeing cells (full resolution) at which support reaches 1 - 1/e:
        about four metres of wall at 0.05 m, below which a match is too small
        to trust.
    distinct_margin : float
        The best transform must explain this much more than the best
        *different* one, as a fraction of its net agreeing cells, for the
        distinctiveness factor to pass one half.
    distinct_width : float
        Width of the distinctiveness logistic, in that fraction; also of the
        mirror factor.
    distinct_by_space : bool
        Whether the best different transform is about as good only when it
        also shares about as much open space (free cells landing on free
        cells): the distinctiveness share is then the smaller of its net
        wall cells and its shared open space, each over the best's. Off by
        default; the default method's look ranked by fit alone turns it on
        (``TomographicParams.fit_ranked``), where the best is the exact fit
        and a rival that lays as many walls on walls but little open space
        on open space (a rectilinear building turned a quarter turn, a wall
        met from the wrong side) explains the walls only.
    mirror_margin : float
        For the default method: the best transform must explain this much
        more than map 2's mirror image laid on the same overlap, as a
        fraction of its net agreeing wall cells there
        (:func:`merging.evidence.mirror.mirror_share`, one minus that share), for the
        mirror factor to pass one half; evidence that looks the same in a
        mirror cannot tell a place from its mirror twin in a mirror-symmetric
        building (:mod:`merging.evidence.mirror`). The mirrored placement competes
        like the best different one, so its margin is set to ``distinct_margin``'s
        value and shares its width (``distinct_width``); it is a setting of its own
        so that either can be changed alone. Looked at
        while choosing the counting (window pairs of four maps, seeds 7 and 5
        of the section 4.1 and low-overlap protocols): of 156 right
        placements a way vouched for, the mirror image explained a median 23 %
        of the evidence and at most 77 % (a corridor entering ``aces3``'s
        round hall, now refused; the next, a plain corridor, 72 %); of the 18
        half-turned placements across that hall (the low-overlap suite of
        ``scripts/bench_real_maps.py`` and the tests), 83-97 %. The factor
        caps the confidence of the way it tests rather than multiplying it
        (:mod:`merging.evidence.verdict`), so a placement is refused in the
        mirror's name only when the factor itself is below ``accept``: the
        mirror image explaining more than about 73 % of the evidence. Wrong
        placements lie below the round hall's range too: ``aces3#19`` of
        low-overlap seed 31415, 924 cells off, has a mirror image explaining
        78 %, and is accepted at a margin of 0.15.
    strength_scale : float
        Constraint strength (matching cells per cell² of motion along the
        weakest direction, :func:`merging.evidence.refine.constraint_strength`) at which
        that factor reaches 1 - 1/e: an overlap of one short wall scores about
        3, a room corner about 30.
    shared_space_scale : float
        Clear free cells landing on clear free cells (both directions
        together) at which the shared-space factor reaches 1 - 1/e: about a
        square metre seen by both robots at 0.05 m. Maps laid side by side
        along one wall share none.
    pin_cells : tuple of float
        Distances (cells RMS over map 2's walls) by which
        :func:`merging.evidence.pinning.pinning` moves a placement whose constraint
        strength is weak, to see what moving it costs: the accuracy a merge
        is asked for (2 cells, ``scripts/bench_merge.py``) and twice that.
    pin_directions : int
        Directions of translation tried at each of those distances, evenly
        spread: 8, every 45 degrees, puts the weakest direction of a straight
        corridor within 22.5 degrees of one of them. Each move is the
        distance in the chessboard metric of the verification's cell
        tolerance (a diagonal move of 2 cells is (2, 2), not (1.4, 1.4),
        which lands every cell next to where it was).
    pin_below : float
        The curvature's constraint factor below which the verdict also
        measures what moving the placement costs: above it the curvature
        alone lets the other factors decide, and the moves are not worth
        their milliseconds.
    pin_scale : float
        Net evidence lost by the cheapest of those moves (cells, both
        directions together: agreeing walls lost plus ``conflict_weight``
        times conflicts gained) at which the constraint factor reaches
        1 - 1/e when the curvature alone would give less: about a metre of
        cross wall at 0.05 m seen in both maps, as a door or corner holding
        a corridor does. A corridor with nothing across it loses nothing,
        and a placement off the truth gains by moving towards it.
    turn_scale : float
        Strength of the turn alone (:func:`merging.evidence.refine.turning_strength`,
        matching cells per cell² of map 2's RMS motion) at which the
        constraint factor reaches 1 - 1/e when the curvature alone would
        give less. Larger than ``strength_scale``: a small overlap turns
        about itself, so the half-cell errors of rasterising a turned map
        there reach map 2's far walls multiplied by its lever arm (map 2's
        radius over the overlap's, 3-16 for right placements of low-overlap
        windows), and the curvature of a flat optimum does not show them.
        Window pairs sharing 3-15 % whose placements were pinned by a turn
        of 11 were accepted 2-4 cells off at 10 (seeds 1001-3003 of
        ``scripts/bench_real_maps.py low-overlap``); with ``max_lever`` and
        the near rival (``TomographicParams.near_rival_turns``) refusing
        those, 10 still accepts one 2.75 cells off on seed 2121, which 15
        refuses.
    turn_return_cells : float
        How near (cells RMS over map 2's walls) the narrow refinement must
        come back to a placement, restarted from it turned about the
        overlap by ``TomographicParams.near_rival_turns`` cells either way,
        for its turn to count as held when the curvature holds it weakly
        (:func:`merging.evidence.verdict.turn_is_held`): half the accuracy a
        merge is asked for (2 cells). On ten seeds of the low-overlap suite
        (``scripts/bench_real_maps.py low-overlap``, 3000 window pairs), 339
        of the 359 right placements asked came back within a cell (median
        0.12); of the 16 wrong ones asked, five did, all 2.3-2.8 cells off
        but one, and were refused after (by ``reverse_gap_cells`` and the
        mirror check).
    slide_return_cells : float
        The same for a slide that costs too little to pin a placement
        (:func:`merging.evidence.verdict.slide_is_held`): restarted from the
        placement slid by each of ``pin_cells`` in ``pin_directions``
        directions, the narrow refinement must come back within this. A
        corridor with nothing across it lets the restarts stay where they
        started. Tighter than the turn's: a placement held both ways is held
        by the sharpness of its optimum alone, with no count of walls. On
        fifteen seeds of the low-overlap suite (4500 window pairs: 2026,
        1717, 1818, 60606, 31415, 92653, 58979, 27182, 11111, 44444, then
        77777, 88888, 99999, 12345 and 54321) 107 of the 169
        right placements asked came back within 0.75 (median 0.19), 69 of
        them then accepted; of the 15 wrong ones asked two did, 19 and 108
        cells off in symmetric parts of ``brsu_c069``, which the mirror check
        refused. Allowed a whole cell, one more came back (0.99) and was
        accepted 2.5 cells off; 0.75 was set on the first ten seeds, the
        last five were drawn after.
    slide_settled_share : float
        A slid restart that ends farther than ``slide_return_cells`` still
        lets the slide count as held when the placement it settles on
        explains at least this share less than the placement judged (net
        wall cells, :attr:`merging.evidence.verify.Verification.net`) and
        still more than it contradicts (net above zero): it fell into a
        worse optimum, not onto a second answer. Along a corridor with
        nothing across it the restarts stay where they started and lose
        nothing. A restart that ends in conflict, slid across the walls out
        of the narrow field's reach, still counts as not back: setting those
        aside too let a placement slid 8.3 m along a corridor whose doors
        repeat be accepted and confirmed in the exploration study (generated
        floor 1, seed 15). On the low-overlap seeds 2026, 4242 and 1717 of
        ``scripts/bench_real_maps.py`` the wrong placements asked lost at
        most 2.3 % at their farther restarts; a flat 30 cells instead of a
        share accepted one 4.3 cells off on seed 44444, whose restarts
        settled 3.4 cells away losing 4.2 %. At 1 or more none is set aside.
    return_fit : float
        The fit quality (agreeing minus weighted conflicting walls, as the
        fit factor counts it) a placement needs for the refinement's coming
        back to hold its turn or its slide: a sharp optimum vouches for the
        truth only where nearly every wall meets its twin. Right placements held that
        way on those seeds fit at 0.983 or better; one 850 cells off, its
        optimum as sharp, at 0.88.
    reverse_gap_cells : float
        For a close fit the curvature holds loosely (its constraint factor
        below ``pin_below``): how far (cells RMS over map 2's walls)
        refining the other way round, map 1 onto map 2, may land from it
        before the confidence halves (:func:`merging.tomographic.restarts.both_ways`):
        the accuracy a merge is asked for. The two directions meet each
        other map's rasterised walls, so their answers straddle the truth
        and the placement reported lies halfway. On those ten seeds 681
        right placements were checked (median 0.23 cells apart, 90 % within
        0.74, three beyond 2) and seven wrong ones (0.7-4.3); before the
        check, five placements 2.3-2.8 cells off were accepted.
    reverse_gap_width : float
        Width (cells) of that logistic: a quarter of a cell, so that a
        reverse landing a cell and a half away costs a tenth of the
        confidence.
    max_lever : float
        Largest lever arm (:func:`merging.evidence.pinning.lever_arm`: how
        many times farther map 2's walls lie from the overlap than the
        overlap's own) at which a close fit may vouch for a placement. The
        narrowest refinement field places the overlap's walls to about a
        tenth of a cell (median; :data:`DEFAULT_STAGES`), a sixth in the
        tail; a turn of that size at the overlap's rim moves walls this many
        times farther out by this many times as much, so beyond
        2 / (1/6) = 12 the accuracy a merge is asked for (2 cells) is not
        held. On the low-overlap window pairs of seeds 41, 2002, 3003, 5005
        and 2026 (``scripts/bench_real_maps.py low-overlap``) accepted right
        placements reached 10; the two accepted 2.5 and 3.6 cells off, 13.6
        and 13.8.
    accept : float
        Confidence at or above which a result is accepted. Set on 4200
        low-overlap window pairs of four real maps (fourteen seeds of the
        suite of ``scripts/bench_real_maps.py``, the benchmark's own seed not
        among them): the share of wrong placements reaching a confidence
        halves with each tenth above 0.4, and at 0.5 eleven in 4200 were
        accepted, three far off and eight 2.5-3.9 cells off, all but one
        below 0.6, where 8 % of the right acceptances lie. A placement that
        goes wrong is worse for a user than one refused, so 0.6.
    """

    fit_centre: float = 0.80
    fit_width: float = 0.06
    fit_tolerance: int = 3
    tolerant_support: float = 2000.0
    support_scale: float = 80.0
    distinct_margin: float = 0.25
    distinct_width: float = 0.05
    distinct_by_space: bool = False
    mirror_margin: float = 0.25
    strength_scale: float = 10.0
    shared_space_scale: float = 1000.0
    pin_cells: tuple[float, ...] = (2.0, 4.0)
    pin_directions: int = 8
    pin_below: float = 0.9
    pin_scale: float = 40.0
    turn_scale: float = 15.0
    turn_return_cells: float = 1.0
    slide_return_cells: float = 0.75
    slide_settled_share: float = 0.1
    return_fit: float = 0.95
    reverse_gap_cells: float = 2.0
    reverse_gap_width: float = 0.25
    max_lever: float = 12.0
    accept: float = 0.6

    def __post_init__(self) -> None:
        _check_fields(
            self,
            positive=(
                "fit_width",
                "support_scale",
                "distinct_width",
                "strength_scale",
                "shared_space_scale",
                "pin_cells",
                "pin_directions",
                "pin_scale",
                "turn_scale",
                "turn_return_cells",
                "slide_return_cells",
                "slide_settled_share",
                "reverse_gap_cells",
                "reverse_gap_width",
                "max_lever",
            ),
            fractions=("pin_below", "return_fit", "accept"),
        )


@dataclass(frozen=True, slots=True)
class RobustParams:
    """The second way to vouch for a merge: much consistent evidence, for maps that bend.

    Maps of one floor from separate sessions or robots bend against each
    other by up to half a metre and draw walls 2-3 cells thick: even the
    right placement lays 20-40 % of one map's walls on the other's open
    space, so the fit factor of :class:`ConfidenceParams` refuses it. Such a
    placement is vouched for instead when *all* of these hold (each a
    logistic factor passing one half at its threshold; the confidence is the
    weakest of them, :func:`merging.evidence.robust.robust_confidence`, so acceptance
    at ``ConfidenceParams.accept`` asks each measure to pass its threshold
    by 0.4 of its narrow width):

    Attributes
    ----------
    margin : float
        Ranking score (:attr:`merging.evidence.verify.Verification.score`) by which the
        placement beats the best *different* one, one farther than
        ``distinct_cells``.
    distinct_cells : float
        Cells (RMS over map 2's walls) a competing placement must lie from
        the placement to count as different for this way of vouching. Maps
        of separate sessions bend against each other by up to half a metre
        (10 cells at 0.05 m), so a placement nearer than that explains the
        same overlap bent a little the other way: one answer, not two.
    bent_rival_cells : float
        A placement refused as ambiguous against a runner-up nearer than
        this (cells RMS over map 2's walls; 3 m at 0.05 m) and turned less
        than ``bent_rival_deg`` is judged again as one answer with it: the
        best rigid compromise over the whole overlap between the two
        (:func:`merging.tomographic.judging.bent_compromise`), held
        against the placements farther than this. Sessions of a floor bend
        against each other by more than ``distinct_cells`` in places: the
        Halmstad F5 sessions refused as ambiguous had runner-ups 12-54
        cells away turned 0-3 degrees, each fitting another part of the
        floor. A near rival of maps that do not bend (a corridor's repeated
        doors) is refused still: the compromise lays walls on open space or
        slides along the corridor, and small maps do not reach
        ``agreeing``.
    bent_rival_deg : float
        The turn (degrees) within which such a runner-up counts as the
        same answer bent.
    agreeing : float
        Wall cells (both directions) that land on walls: a large overlap,
        about 400 m of wall at 0.05 m. Right E5 session placements this way
        vouches for have 11 400 or more. Wrong placements of low-overlap
        window pairs reached 4400 on the seeds this was first set on (the
        threshold was 5000), but 5270-5790 on fresh seeds: ``aces3``'s
        corridor loops, near copies of each other turned by quarter and half
        turns, laid on one another, each about 750 cells off (five of 3000
        pairs of seeds 31, 77, 101, 202, 303, 404, 505, 606, 707, 808 of
        ``scripts/bench_real_maps.py low-overlap``). 8000, the geometric
        middle of that gap, refuses those five and no right placement of
        those seeds or of the benchmark suites.
    tolerance : int
        Cells (chessboard) within which a carried wall cell counts as
        agreeing for the tolerant fit: the bending seen between sessions.
    agreement : float
        Fraction of carried wall cells within ``tolerance`` of a wall.
    quality : float
        Tolerant quality, agreement minus ``VerifyParams.conflict_weight``
        times the fraction landing on clear free space beyond the tolerance.
    open_share : float
        Shared clear free space (both directions) over twice the smaller
        map's clear free space: how much of the maps' open space overlaps.
    open_consistency : float
        Of the clear free cells carried onto known cells of the other map,
        the fraction landing on its clear free space. Right session pairs of
        E5 score 0.93-0.97 and ``intel`` against ``intel_raster`` (two
        sources of one building) 0.906; wrong E5 placements that overlap a
        lot, 0.90-0.91, and wrong low-overlap windows with much agreeing
        wall, below 0.89.
    strength : float
        Constraint strength, the largest over the curvature widths of
        ``GaussNewtonParams.curvature_sigma`` and ``strength_widths`` (each
        scaled by its width squared, to matching cells per cell² at one
        cell): ragged walls make the sharpest curvature noisy, but a corridor
        that lets the maps slide stays weak at every width.
    strength_widths : tuple of float
        The wider curvature widths, in cells.
    widths : tuple of float
        Logistic widths of the factors, in the units of each threshold
        (margin, log10 of agreeing, agreement, quality, open share, open
        consistency, log10 of strength): narrow, so that each is nearly a
        pass-fail test.

    These thresholds were set on the even-numbered of the 109 E5 session
    pairs (sorted by name) and on window pairs of four maps (seeds 2020, 11
    and 3). The odd-numbered E5 pairs then showed three placements 30-37
    cells off accepted, which ``quality`` now refuses, so they are no clean
    hold-out; 300 low-overlap window pairs of seed 2026 and the simulated
    episodes of ``scripts/calibrate_confidence.py`` are
    (``scripts/bench_real_maps.py``).
    """

    margin: float = 0.3
    distinct_cells: float = 10.0
    bent_rival_cells: float = 60.0
    bent_rival_deg: float = 5.0
    agreeing: float = 8000.0
    tolerance: int = 4
    agreement: float = 0.5
    quality: float = -0.4
    open_share: float = 0.2
    open_consistency: float = 0.90
    strength: float = 2.0
    strength_widths: tuple[float, ...] = (2.0, 4.0)
    widths: tuple[float, float, float, float, float, float, float] = (
        0.03,
        0.02,
        0.02,
        0.03,
        0.02,
        0.005,
        0.05,
    )

    def __post_init__(self) -> None:
        _check_fields(
            self,
            positive=("strength_widths", "widths"),
            fractions=("agreement", "open_share", "open_consistency"),
        )


@dataclass(frozen=True, slots=True)
class GaussNewtonParams:
    """The Gauss-Newton fit of map 2's walls to map 1's blurred walls.

    Used by :mod:`merging.evidence.refine`.

    Attributes
    ----------
    newton_factor : float
        Step multiplier turning the half-way Gauss-Newton step into Newton's
        step (see :mod:`merging.evidence.refine`).
    backtracks : int
        Times a step is halved when it lowers the objective, before giving up.
    damping : float
        Levenberg damping, relative to the mean diagonal of the normal matrix.
    max_step_cells : float
        A longer step is shortened: the linearisation holds only near walls.
    max_step_sigmas : float
        ... unless the field is wide: a step may be this many field widths
        long, so that the wide fields of a coarse-to-fine search can travel.
    converged_cells : float
        A step moving map 2's cells less than this (in translation and, RMS,
        in rotation) ends a stage: far below the 2-cell accuracy asked for.
    local_margin : float
        Cells beyond where map 2 lands that a local field covers: room for
        the last steps of a refinement that starts within a cell or so.
    downsample_from_sigma : float
        Fields at least this wide (cells) are computed on a coarser grid, of
        the largest power of two not above the width (at least 2) cells a
        pixel (:func:`merging.evidence.refine.field_scale`): a blur of two
        cells has nothing finer to keep, and a field of 8 cells has a
        sixty-fourth of the pixels.
    curvature_sigma : float
        Field width (cells) on which the constraint strength measures
        curvature; ``ConfidenceParams.strength_scale`` was set on this width.
    curvature_step : float
        Finite-difference step, in cells of RMS motion of map 2, for that
        curvature: one cell spans the sharp field's peak.
    curvature_points : int
        Map 2 cells used for the curvature.
    whole_field_share : float
        Share of map 1's area above which a local field is the whole map's
        (cached) one: its values are the same where map 2 lands, and every
        candidate and the curvature reuse it.
    """

    newton_factor: float = 2.0
    backtracks: int = 2
    damping: float = 1e-3
    max_step_cells: float = 3.0
    max_step_sigmas: float = 1.0
    converged_cells: float = 0.05
    local_margin: float = 4.0
    downsample_from_sigma: float = 2.0
    curvature_sigma: float = 1.0
    curvature_step: float = 1.0
    curvature_points: int = 1500
    whole_field_share: float = 0.5

    def __post_init__(self) -> None:
        _check_fields(
            self,
            positive=(
                "newton_factor",
                "downsample_from_sigma",
                "curvature_sigma",
                "curvature_step",
            ),
            fractions=("whole_field_share",),
        )
        real_number(self.damping, "GaussNewtonParams.damping", low=0.0)
        # Halved 52 times a step is below a float's precision of it: more only costs time.
        if self.backtracks > 52:
            raise ValueError(
                f"GaussNewtonParams.backtracks must be a whole number in [0, 52], "
                f"got {self.backtracks!r}"
            )
        # A curvature of three parameters (turn and shift) needs three cells at least.
        whole_number(self.curvature_points, "GaussNewtonParams.curvature_points", minimum=3)


@dataclass(frozen=True, slots=True)
class RefineStage:
    """One row of the refinement schedule: which candidates, how wide a field, how long.

    At each stage, ``admit`` further candidates (in screening order) join the
    pool, verified in full; the pool is ranked; its best ``refine`` are
    refined on fields of widths ``sigmas``, each for at most ``iterations``
    Gauss-Newton steps, moving at most ``points`` of map 2's cells.

    Attributes
    ----------
    admit : int
        Screened candidates added to the pool before this stage.
    refine : int
        Best candidates of the pool refined in this stage.
    sigmas : tuple of float
        Field widths in cells, widest first.
    iterations : int
        Gauss-Newton steps per width at most.
    points : int
        Map 2 cells moved per step at most.
    local : bool
        Blur only the part of map 1 where map 2 lands: for candidates already
        within a cell or so.
    """

    admit: int
    refine: int
    sigmas: tuple[float, ...]
    iterations: int
    points: int
    local: bool

    def __post_init__(self) -> None:
        _check_fields(self, positive=("sigmas",))


DEFAULT_STAGES = (
    # The widest field catches a coarse hypothesis a few cells off: every candidate
    # refined there gets into the next field's reach; 600 cells are enough for that.
    RefineStage(admit=5, refine=5, sigmas=(2.0,), iterations=5, points=600, local=False),
    # One cell pins the optimum to a fraction of a cell; only the two best need it
    # to be ranked, the others only the widest field's first steps.
    RefineStage(admit=0, refine=2, sigmas=(1.0,), iterations=10, points=1500, local=True),
    # Three more candidates compete unrefined for the final choice and the runner-up;
    # the winner alone resolves the last tenth of a cell on 0.6 cells (the median
    # error halves, to about 0.1 cell). Converging the last tenth of a degree over
    # a map 1000 cells wide takes up to ten steps.
    RefineStage(admit=3, refine=1, sigmas=(0.6,), iterations=10, points=1500, local=True),
)
"""The refinement schedule of the default method, walked by one loop."""

MIRROR_STAGES = DEFAULT_STAGES[:2]
"""The refinement schedule of the search for the mirror image of the evidence: the
first two stages of :data:`DEFAULT_STAGES`. Its placements are counted within a
cell of a wall, so the last tenth of a cell the final stage resolves does not
change them, and leaving it out saves about a quarter of that search's time."""

COMPROMISE = RefineStage(
    admit=1, refine=1, sigmas=(8.0, 4.0), iterations=15, points=3000, local=False
)
"""Refining an accepted placement of maps that bend against each other to the best rigid
compromise over the whole overlap (:func:`merging.tomographic.restarts.rigid_compromise`): fields as
wide as the bending between sessions (up to half a metre, 10 cells at 0.05 m) and half
that, over all of map 1, with twice the points of the other stages, as the parts that
bend away are what the compromise weighs. On a third of the E5 session pairs (every
third, sorted by name) the largest error of an accepted placement fell from 0.75 to 0.56
of its tolerance, the median error stayed 3 cells. The constraint strength of a compromise
with a near rival is measured on these fields too
(:func:`merging.tomographic.judging.with_compromise_curvature`)."""

FROM_START = RefineStage(
    admit=1, refine=1, sigmas=(2.0, 1.0, 0.6), iterations=10, points=1500, local=True
)
"""Refining one given transform (a previous round's, say) that is within a few
cells of the answer: all three field widths in turn, over where map 2 lands."""


@dataclass(frozen=True, slots=True)
class TomographicParams:
    """Every setting of the default method, grouped by stage.

    Attributes
    ----------
    rotation, translation, verify, confidence, robust, gauss_newton
        The stage settings (see each class).
    stages : tuple of RefineStage
        The refinement schedule, walked in order.
    from_start : RefineStage
        How :func:`merging.tomographic.search.refine_from` refines a given transform.
    mirror_stages : tuple of RefineStage
        The refinement schedule of the search for the mirror image of the
        evidence (:mod:`merging.evidence.mirror`).
    mirror_significant_peaks : int
        ``TranslationParams.significant_peaks`` of the search for the mirror
        image of the evidence: none. The significant shifts find a small
        overlap of a large map 2; the mirrored part is the overlap and its
        margin, so its twin lays most of its walls on map 1's ground and
        the collected mass ranks it, and the search skips two of its four
        correlations per rotation. On sixteen low-overlap seeds (the fifteen
        of ``ConfidenceParams.slide_return_cells`` and 4242) no wrong answer was
        accepted with six or with none, and the search for the twin took a
        fifth less time.
    compromise : RefineStage
        How an accepted placement of maps that bend against each other is
        refined to the best rigid compromise over the whole overlap
        (:data:`COMPROMISE`).
    correlation_refined : int
        Of the candidates admitted to the first stage, how many are taken by
        correlation strength rather than by verification: before refinement
        a true but slightly misaligned transform can fit worse than one that
        lays a single outer corner on a corner, which the correlation
        (weighing how much overlaps) does not favour.
    significance_refined : int
        Of the candidates admitted to the first stage, how many more are
        taken as the most significant shifts
        (``TranslationParams.significant_peaks``): a small overlap's true
        shift, slightly misaligned, verifies worse than loose large overlaps
        until it is refined.
    close_alternative : float
        Quality (:attr:`merging.evidence.verify.Verification.quality`) at or above
        which a placement of the pool is judged too when the best by score
        is refused: walls meeting within a cell with almost no conflict.
        The ranking score prefers much shared open space, which maps of
        separate sessions need, and so may rank a loose large overlap above
        the exact small one of maps that share 3-15 % of their area; the
        verdict, not the score, then decides. Right placements of such
        window pairs score 0.95-1 (``scripts/bench_real_maps.py
        low-overlap``, seed 41), wrong ones the score preferred -1.2-0.9.
    fit_ranked : bool
        When the verdict refuses the pool's first placement, rank the same
        hypotheses again by fit alone, refine them and judge that pool's
        first (:func:`merging.tomographic.search.ranked_by_fit`): with
        ``VerifyParams.space_preference`` 0 and
        ``ConfidenceParams.distinct_by_space``. The default ranking prefers
        much shared open space, which maps of separate sessions need (ranked
        by fit alone no E5 session pair is right) and which ranks a loose
        large overlap above the exact small one of maps sharing 3-15 % of
        their area (ranked by fit alone, 71-80 % of those windows are
        placed right against 57-63 %). Only refusals are looked at again,
        so whatever the first look accepts stays as it was.
    widest_per_block : float
        Widest field of the first refinement stage, in blocks of the coarse
        correlation grid: its hypotheses are off by up to half a block plus
        their rotation error (see :func:`merging.tomographic.hypotheses.coarse_to_fine`).
        Below 6 blocks' worth of map (800 cells) no wider field is added.
    keep_refined_margin : float
        Score by which a refined transform may verify worse than its start
        and still be kept: about one wall cell in fifty landing one cell
        farther out (verification tolerates a cell of misfit, so it cannot
        rank finer than that). For the same reason a rival within it of the
        placement's score ties it by the walls, and the second look does not
        accept a placement over such a rival for the open space it shares
        (:func:`merging.tomographic.search.outexplained_by_rival`).
    distinct_cells : float
        Two transforms moving map 2's cells further apart than this (cells
        RMS) are different answers; closer ones are one answer found twice.
    near_rival_turns : tuple of float
        RMS motions of map 2's walls (cells) by which a placement about to be
        accepted is turned about the overlap, either way, before refining it
        again to look for a near rival
        (:func:`merging.tomographic.restarts.turned_rival`): the accuracy a merge is asked
        for (2 cells) and twice that.
    near_rival_cells : float
        A placement farther than this (cells RMS over map 2's walls) from
        the one judged is a rival: the accuracy a merge is asked for. One
        that explains nearly as much (the distinctiveness factor of
        ``ConfidenceParams``) makes the placement ambiguous.
    """

    rotation: RotationParams = field(default_factory=RotationParams)
    translation: TranslationParams = field(default_factory=TranslationParams)
    verify: VerifyParams = field(default_factory=VerifyParams)
    confidence: ConfidenceParams = field(default_factory=ConfidenceParams)
    robust: RobustParams = field(default_factory=RobustParams)
    gauss_newton: GaussNewtonParams = field(default_factory=GaussNewtonParams)
    stages: tuple[RefineStage, ...] = DEFAULT_STAGES
    from_start: RefineStage = FROM_START
    mirror_stages: tuple[RefineStage, ...] = MIRROR_STAGES
    mirror_significant_peaks: int = 0
    compromise: RefineStage = COMPROMISE
    correlation_refined: int = 2
    significance_refined: int = 2
    close_alternative: float = 0.95
    fit_ranked: bool = True
    widest_per_block: float = 0.75
    keep_refined_margin: float = 0.02
    distinct_cells: float = 4.0
    near_rival_turns: tuple[float, ...] = (2.0, 4.0)
    near_rival_cells: float = 2.0

    def __post_init__(self) -> None:
        _check_fields(self, positive=("near_rival_turns", "near_rival_cells", "distinct_cells"))
        for name in ("stages", "mirror_stages"):
            _check_schedule(name, getattr(self, name))


def _check_schedule(name: str, stages: tuple[RefineStage, ...]) -> None:
    """Raise naming ``name`` unless ``stages`` (RefineStages, at least one, as
    :func:`_check_fields` has checked) is a schedule the refinement can walk."""
    for k, stage in enumerate(stages):
        if stage.refine < 1 or stage.iterations < 1 or stage.points < 3 or not stage.sigmas:
            raise ValueError(
                f"{name}[{k}] must refine at least one candidate with at least one "
                f"field, step and three points, got {stage}"
            )
    if stages[0].admit < 1:
        raise ValueError(f"the first stage of {name} must admit at least one candidate")


DEFAULT_PARAMS = TomographicParams()
"""The settings :func:`merging.estimate_transform` uses unless given others."""


@dataclass(frozen=True, slots=True)
class LinkingParams:
    """When a pair is dropped as contradicting the others: how far chained transforms may
    disagree, and how many walls a join may lay on open space across it.

    Used by :func:`merging.link_maps` and :func:`merging.merge_all`
    (:mod:`merging.linking.forest`, steps 2 and 5; :mod:`merging.linking.across`)
    for any method.

    Attributes
    ----------
    contradiction_cells : float
        Cells RMS, over the grid's occupied cells, by which a pair must
        disagree with a chain of others to be dropped: half a metre at
        0.05 m. Transforms chained from right merges of drifting robots'
        maps stay within a few cells of each other; a wrong match is off by
        a room or by tens of degrees.
    bent_contradiction_cells : float
        The same for a comparison involving a pair vouched for as maps that
        bend (separate sessions of a floor,
        :func:`merging.linking.forest.bends`): each such pair is right only
        to within the bending, so the three of a triangle of right pairs
        miss by up to 47 cells RMS (42 on the Halmstad E5 floor's 122
        accepted triangles, 47 on F5's 39: ``scripts/bench_cycles.py``),
        where the wrong placements the bending evidence once accepted lay
        285-910 cells off. Three metres at 0.05 m.
    across_conflict : float
        Share of the wall cells of two maps placed through a new link (maps
        of the two groups it joins, not the pair itself) that meet the other
        map's known cells and land on its clear open space, above which the
        link is dropped (:mod:`merging.linking.across`; both ways, as
        :attr:`merging.evidence.verify.Verification.conflict` counts them;
        1 never drops one).
        In exploration with 4 robots on generated floors 0-2, seeds 0-63
        (``scripts/exploration_confidences.py``, 192 episodes), the 3037
        right estimates the linking judged (one per pair and round) laid at
        most 0.12 of those walls on open space (0.05 for 99 % of them, 0.002
        in the median); the one false match joining groups, a room matched
        to its twin half a turn away (``floor1`` seed 48, in its three
        confirmed rounds, confidence 0.64-0.69), laid 0.54-0.56. A quarter
        lies between, about as far from either in ratio. A false match that
        slides a map along a corridor whose doors repeat lays the maps
        across wall on wall (0.00 for the one seen, never confirmed): the
        check cannot see it.
    across_overlap_cells : float
        Wall cells of two such maps that must meet the other map's known
        cells (both ways, :attr:`~merging.evidence.verify.Verification.overlap`)
        for them to be judged: below it a few stray cells make the share.
    """

    contradiction_cells: float = 10.0
    bent_contradiction_cells: float = 60.0
    across_conflict: float = 0.25
    across_overlap_cells: float = 100.0

    def __post_init__(self) -> None:
        _check_fields(
            self,
            positive=("contradiction_cells", "bent_contradiction_cells", "across_overlap_cells"),
            fractions=("across_conflict",),
        )


DEFAULT_LINKING = LinkingParams()
"""The settings :func:`merging.link_maps` uses unless given others."""
