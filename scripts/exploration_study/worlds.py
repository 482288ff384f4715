"""The worlds of the study: generated floors by seed, real maps by name."""

from __future__ import annotations

from dataclasses import dataclass

from merging.catalog import find_map, is_map_path
from tomosim.episode import EpisodeConfig

DEFAULT_WORLDS = ("0", "1", "2", "aces3", "fr079")
"""Three generated floors and two real buildings."""
FLOOR_STEPS = 4000
"""Step cap (0.1 s each) on generated floors: room for one robot alone to reach 90 %
(teams stop at 90 % long before; a cap only ends episodes that do not get there)."""
REAL_MAP_STEPS = {"aces3": EpisodeConfig.steps, "fr079": 6000}
"""Step caps of the real maps: ``aces3``'s is the default cap, within which 4 robots
must reach 90 %; ``fr079`` has four times ``aces3``'s free space."""


@dataclass(frozen=True, slots=True)
class StudyWorld:
    """One world of the study.

    Attributes
    ----------
    token : str
        As given on the command line (a seed or a map name).
    spec : str
        What :func:`tomosim.episode.load_world` takes: the seed, the map's name, or the
        YAML path.
    label : str
        Its name in tables and file names (``floor0``, ``aces3``).
    generated : bool
        A generated floor (True) or a real map.
    steps : int
        Step cap of its episodes.
    """

    token: str
    spec: str
    label: str
    generated: bool
    steps: int


def resolve(token: str, steps: int | None = None) -> StudyWorld:
    """The world named by ``token``: a seed, the name of a shared map, or a YAML path.

    Raises
    ------
    SystemExit
        When a named map cannot be found (with what to do).
    """
    if token.isdigit():
        return StudyWorld(token, token, f"floor{token}", True, steps or FLOOR_STEPS)
    try:
        path = find_map(token)
    except FileNotFoundError as exc:
        raise SystemExit(f"world {token!r}: {exc}") from None
    if not path.is_file():
        raise SystemExit(f"world {token!r}: no map file {path}")
    cap = steps or REAL_MAP_STEPS.get(path.stem, EpisodeConfig.steps)
    # A map of the maps path is named by its name, which holds on every machine.
    spec = str(path) if is_map_path(token) else token
    return StudyWorld(token, spec, path.stem, False, cap)
