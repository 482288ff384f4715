"""Every setting of a team, in one frozen object: :class:`TeamConfig`.

A team's merging (method, rounds, confirmation, tracking, linking), its map
sharing, its communication and its simulation are set here and nowhere else:
the episode (:class:`tomosim.episode.EpisodeConfig`, field ``team``), the
PettingZoo environment (``parallel_env(team=...)``), ``tomosim explore`` and
``tomosim sweep`` (which build one from their options) all hand the same
object to :class:`~tomosim.team.TeamSession`. Change a setting with a copy::

    from dataclasses import replace
    from tomosim.team import TeamConfig, TrackingParams

    team = TeamConfig(merge_interval=100, tracker=TrackingParams(keep_confidence=0.55))
    quiet = replace(team, merge=False)

Each field is checked when the object is made (:mod:`merging.validators`), so
that a bad value is refused where it is given, naming it.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field, replace

from merging.api import DEFAULT_METHOD
from merging.params import DEFAULT_PARAMS, LinkingParams, TomographicParams
from merging.validators import SettingTypeError, boolean, real_number, whole_number
from tomosim.simulation import SimulationConfig
from tomosim.team.comms import CommsConfig
from tomosim.team.oracle import ORACLE, check_team_method


@dataclass(frozen=True, slots=True)
class TrackingParams:
    """When a tracked pair is searched again, and how a track starts and is kept.

    Used by :class:`~tomosim.team.link_tracking.TrackingEstimator` (steps 2 and
    3 of its module docstring).

    Attributes
    ----------
    search_every_rounds : int
        Rounds of tracking after which a pair is searched globally again: a
        second opinion, should the track have locked onto a wrong fit.
    search_growth : float
        Fraction of new occupied cells (in either map, since the pair's last
        search) that makes an untracked pair worth searching again, if they
        are also at least ``search_min_new_walls``: a pair refused on the
        same walls would be refused again.
    search_min_new_walls : int
        New occupied cells an untracked pair needs at least, whatever the
        fraction: on a small map a few new cells are a large fraction of its
        walls but little new evidence.
    new_track_quality : float
        Plain fit (``evidence["quality"]``: agreement minus the weighed
        conflict, with no tolerance for bent maps) a search's placement must
        reach on the current maps to start a track: the centre of the default
        method's fit factor (``ConfidenceParams.fit_centre``). Every later
        round verifies a track without the search's runner-up and mirror
        checks, so it must begin where both maps' walls meet cell for cell, as
        a team's maps (one sensor model, slow drift) mostly do where a
        placement is right. In 30 episodes of the exploration study, 129 of
        the 131 right placements that started tracks fitted at 0.87 or better
        and two, in the cluttered ``fr079``, at 0.72 and 0.76 (they now wait
        for a later search); the one that started a wrong track (a half turn
        of ``aces3``'s round hall, accepted on the fit tolerant of bent maps,
        0.90) fitted at 0.78.
    keep_confidence : float
        Confidence at which a track, once started, is kept (new placements
        need ``ConfidenceParams.accept``, 0.6): hysteresis, as trackers
        confirm and drop tracks at two thresholds. A track began at a
        placement accepted and fitting closely, and every round since has
        verified it where it was; as robots' maps grow they bend against each
        other, and a right track's confidence sinks, in the cluttered
        ``fr079`` of the exploration study to 0.51-0.65. Held to 0.6, one
        episode there kept dropping its tracks, lost all its links and took
        twice as long (499 s against 254 s) with no wrong merge avoided. 0.5
        is what every track was held to before acceptance moved to 0.6, over
        352 study episodes without a false match.
    search_unlinked_at_once : bool
        Search a pair in the round itself, and use the result at once, while
        no chain of tracked pairs links its two maps
        (:meth:`~tomosim.team.link_tracking.TrackingEstimator.prepare`);
        otherwise a search's result is used at the pair's next round. Robots
        whose maps are not linked re-explore what the other has seen, so the
        link is worth a round; pairs linked through teammates already wait.
        The worker process and the session's share these searches, so the
        session waits for them. Such a search ran on the round's own maps,
        so its verdict is taken as it is, not refined and judged again.
    """

    search_every_rounds: int = 4
    search_growth: float = 0.1
    search_min_new_walls: int = 20
    new_track_quality: float = DEFAULT_PARAMS.confidence.fit_centre
    keep_confidence: float = 0.5
    search_unlinked_at_once: bool = True

    def __post_init__(self) -> None:
        whole_number(self.search_every_rounds, "search_every_rounds", minimum=1, unit="rounds")
        real_number(self.search_growth, "search_growth", low=0.0)
        whole_number(self.search_min_new_walls, "search_min_new_walls", minimum=0, unit="cells")
        real_number(self.new_track_quality, "new_track_quality", high=1.0)
        real_number(self.keep_confidence, "keep_confidence", low=0.0, high=1.0)
        boolean(self.search_unlinked_at_once, "search_unlinked_at_once")

    def keep_params(self, params: TomographicParams = DEFAULT_PARAMS) -> TomographicParams:
        """``params`` with the acceptance threshold of a kept track, :attr:`keep_confidence`."""
        return replace(params, confidence=replace(params.confidence, accept=self.keep_confidence))


@dataclass(frozen=True)
class TeamConfig:
    """How a team explores: merging, map sharing, communication and the simulation.

    Attributes
    ----------
    merge : bool
        Whether the robots' maps are merged at all (off: each robot explores
        on its own map, the lower bound).
    method : str
        Merging method (:func:`merging.available_methods`), or ``"oracle"``:
        the true relative start poses (:mod:`tomosim.team.oracle`), the upper
        bound.
    merge_interval : int
        Steps between merge rounds: 50, 5 s at the default 0.1 s a step. A
        round estimates every pair of maps, so its time grows with the square
        of the team; between two rounds each robot sees a few metres of new
        walls. Every benchmark and study of the project ran with 50.
    unlinked_merge_interval : int
        Steps between merge rounds while the robots' maps are not all linked
        into one (from the start, and whenever the last round left them in
        more than one group; the shorter of this and ``merge_interval`` is
        used): 10, 1 s. Robots whose maps are not linked explore without each
        other's maps and re-explore what the others have seen, so a link is
        worth having as soon as the maps allow it; rounds cost computing
        time, not simulated time, and a global search is run only when a
        pair's maps have gained walls since its last one (``tracker``).
        Setting it to ``merge_interval`` keeps one interval throughout.
    confirmations : int
        Consecutive rounds that must accept consistent estimates of a pair
        before the pair links maps (1: use an estimate as soon as it is
        accepted): a single wrong match, which would make a robot plan
        through walls, rarely repeats itself in the next round, which sees
        more of both maps (:class:`~tomosim.team.merger.TeamMerger`). A
        round whose estimate is a track kept below the confidence a new
        placement needs (``tracker.keep_confidence``) holds a pair's run but
        does not lengthen it: the track refined its own placement, and a
        wrong one holds as well as the round before on maps that barely grew.
    confirm_at_once_confidence : float or None
        An accepted estimate at least this confident links maps in the round
        that found it, without waiting for ``confirmations`` rounds (None:
        every estimate waits); it counts as the whole run, so the rounds after
        it keep the link as they keep one confirmed round by round. Links
        matter most early, while the maps are small and the robots re-explore
        what the others have seen; the false matches the merger accepted in
        exploration on generated floors stayed below 0.8, while a third of the
        pairs' first right acceptances reached 0.85
        (``scripts/exploration_confidences.py``,
        docs/benchmarks/exploration.md). The oracle's estimates, at
        confidence 1, link at once.
    confirm_rotation_deg : float
        Degrees two rounds' estimates of one pair may differ by and still
        confirm each other: odometry drift moves an estimate by well under a
        degree between rounds, while a wrong match is off by tens of degrees
        or by whole rooms.
    confirm_translation_m : float
        Metres two rounds' estimates may differ by (where each puts the
        second robot's start position) and still confirm each other; same
        reasoning.
    oracle_error_deg, oracle_error_m : float
        Used by ``method="oracle"`` only (as ``merger`` by the default method
        only, so that a sweep over both methods carries both's settings;
        :func:`settings_for_other_methods`, by which the commands refuse them
        for a run that has no oracle): each pair's true transform turned by this
        many degrees and its second robot's start moved by this many metres,
        a fixed error per pair (its direction drawn from the pair's robots),
        the same every round (0, 0: exact). An oracle as accurate as a merger
        tells what the merger's accuracy costs a team, apart from when it
        links; in the exploration study, an error of 0.4 degrees and 0.1 m
        (the merger's typical one) moves single episodes' time to 90 % by
        as much as the merger does (docs/benchmarks/exploration.md).
    oracle_min_shared_m2 : float
        Used by ``method="oracle"`` only: square metres of free space two robots' maps
        must share (under the true transform) before the oracle accepts their
        pair (0: at once, whatever the maps hold). A merger working from the
        grids links a pair only once its maps overlap; an oracle held to that
        tells what the wait costs a team apart from the merger
        (:mod:`tomosim.team.oracle`).
    share_interval : int
        Steps between updates of a linked robot's view of its teammates' maps
        (:mod:`tomosim.team.sharing`): 10, 1 s at the default step, in which a
        robot moves at most a metre; rebuilding the view warps every linked
        teammate's grid, too much work for every step.
    tracking : bool
        With the default (tomographic) method: track linked pairs' transforms
        between rounds and search globally only when needed
        (:class:`~tomosim.team.link_tracking.TrackingEstimator`); other methods
        always search every pair.
    tracker : TrackingParams
        When tracked pairs are searched again, and how a track starts and is
        kept.
    merger : TomographicParams
        The default (tomographic) method's settings, for the team's global
        searches and tracking (a kept track's threshold is
        ``tracker.keep_confidence`` still); by name on the command line as
        ``--team merger.confidence.accept=0.7`` (:mod:`merging.settings`).
        Other methods take no settings and leave it unused (a sweep over
        methods applies it to the default method's episodes).
    merge_worker : bool
        Run the tracker's global searches in a worker process (the results,
        collected at a fixed later round, are the same either way).
    linking : LinkingParams
        When a pair is dropped as contradicting the others: how far chained
        estimates may disagree, and how many walls a join of two groups may
        lay on open space across it (:func:`merging.link_maps`).
    comms : CommsConfig
        Communication range (default unlimited; :mod:`tomosim.team.comms`).
    simulation : SimulationConfig
        Robots, lidar, odometry and mapping.
    """

    merge: bool = True
    method: str = DEFAULT_METHOD
    merge_interval: int = 50
    unlinked_merge_interval: int = 10
    confirmations: int = 2
    confirm_at_once_confidence: float | None = 0.85
    confirm_rotation_deg: float = 3.0
    confirm_translation_m: float = 0.5
    oracle_error_deg: float = 0.0
    oracle_error_m: float = 0.0
    oracle_min_shared_m2: float = 0.0
    share_interval: int = 10
    tracking: bool = True
    tracker: TrackingParams = field(default_factory=TrackingParams)
    merger: TomographicParams = DEFAULT_PARAMS
    merge_worker: bool = True
    linking: LinkingParams = field(default_factory=LinkingParams)
    comms: CommsConfig = field(default_factory=CommsConfig)
    simulation: SimulationConfig = field(default_factory=SimulationConfig)

    def __post_init__(self) -> None:
        check_team_method(self.method)
        for name in ("merge_interval", "unlinked_merge_interval", "share_interval"):
            whole_number(getattr(self, name), name, minimum=1, unit="steps")
        whole_number(self.confirmations, "confirmations", minimum=1, unit="rounds")
        for name in ("merge", "tracking", "merge_worker"):
            boolean(getattr(self, name), name)
        if self.confirm_at_once_confidence is not None:
            real_number(
                self.confirm_at_once_confidence, "confirm_at_once_confidence", low=0.0, high=1.0
            )
        real_number(self.confirm_rotation_deg, "confirm_rotation_deg", low=0.0, unit="degrees")
        real_number(self.confirm_translation_m, "confirm_translation_m", low=0.0, unit="metres")
        real_number(self.oracle_error_deg, "oracle_error_deg", low=0.0, unit="degrees")
        real_number(self.oracle_error_m, "oracle_error_m", low=0.0, unit="metres")
        real_number(
            self.oracle_min_shared_m2, "oracle_min_shared_m2", low=0.0, unit="square metres"
        )
        for name, kind in (
            ("tracker", TrackingParams),
            ("merger", TomographicParams),
            ("linking", LinkingParams),
            ("comms", CommsConfig),
            ("simulation", SimulationConfig),
        ):
            value = getattr(self, name)
            if not isinstance(value, kind):
                raise SettingTypeError(
                    f"{name} must be a {kind.__name__}, got {type(value).__name__}"
                )

    def search_options(self) -> dict[str, TomographicParams]:
        """The keyword arguments a global search of :attr:`method` takes from the team:
        ``params=`` :attr:`merger` for the default method, none for the others."""
        return {"params": self.merger} if self.method == DEFAULT_METHOD else {}


METHOD_SETTINGS: dict[str, str] = {
    "tracking": DEFAULT_METHOD,
    "tracker": DEFAULT_METHOD,
    "merger": DEFAULT_METHOD,
    "oracle_error_deg": ORACLE,
    "oracle_error_m": ORACLE,
    "oracle_min_shared_m2": ORACLE,
}
"""The fields of :class:`TeamConfig` that only one merging method uses, and that method."""


def settings_for_other_methods(team: TeamConfig, methods: Iterable[str]) -> dict[str, str]:
    """The fields of :data:`METHOD_SETTINGS` that ``team`` changes from the defaults for a
    method none of ``methods`` is, each with the method that uses it (empty: none).

    A team carries every method's settings, each used by its own method only: a sweep
    over the tomographic method and the oracle can set both's. A changed setting that
    no method of a run uses is a mistake the commands refuse
    (:mod:`tomosim.commands.team_options`).
    """
    default = TeamConfig()
    wanted = set(methods)
    return {
        name: method
        for name, method in METHOD_SETTINGS.items()
        if method not in wanted and getattr(team, name) != getattr(default, name)
    }


def for_method(team: TeamConfig, method: str, *, merge: bool = True) -> TeamConfig:
    """``team`` merging with ``method`` (``merge=False``: not at all), the settings of
    :data:`METHOD_SETTINGS` that another method uses back at their defaults.

    What an episode of a sweep runs with: a sweep over several methods carries each
    one's settings in one team, and an episode's recorded settings then name only
    those its own method used.
    """
    default = TeamConfig()
    used = method if merge else None
    reset = {
        name: getattr(default, name)
        for name, owner in METHOD_SETTINGS.items()
        if owner != used and getattr(team, name) != getattr(default, name)
    }
    return replace(team, merge=merge, method=method, **reset)
