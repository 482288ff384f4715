"""The paper's published figures that the report sets beside ours (Tables 2 and 3).

:data:`PAPER_MATCHING` and :data:`PAPER_SECONDS` are keyed by the paper's row
group (``"Sim."`` or ``"Exp."``) and then by the paper's name of the method
(:attr:`paper_comparison.contenders.Contender.paper_label`), giving
``(mean, standard deviation)``.
"""

from __future__ import annotations

Figures = tuple[float, float, float, float]
"""``(Sim. mean, Sim. standard deviation, Exp. mean, Exp. standard deviation)``."""

PUBLISHED: dict[str, tuple[Figures | None, Figures]] = {
    # the paper's name: (matching index of Table 2, seconds of Table 3)
    "Proposed": ((0.9457, 0.0334, 0.9393, 0.0552), (7.6219, 1.1282, 0.3766, 0.0432)),
    "Proposed w/o MCO": (None, (3.3047, 0.3013, 0.1781, 0.0223)),
    "SMM": ((0.5970, 0.4442, 0.6665, 0.1557), (3.1527, 0.4235, 0.1531, 0.1263)),
    "SURF": ((0.7244, 0.2553, 0.0543, 0.0483), (5.3756, 0.3948, 0.2198, 0.0480)),
    "HCD": ((0.3209, 0.4122, 0.6507, 0.2668), (4.7475, 0.4463, 0.4297, 0.0907)),
    "MEV": ((0.3487, 0.4140, 0.0596, 0.0658), (4.8870, 0.3995, 0.3017, 0.0613)),
    "REG": ((0.2351, 0.3292, 0.0756, 0.0232), (17.3969, 1.2543, 0.6509, 0.1208)),
}
"""Each method's published figures, one line per column of the paper's tables
(Table 2 has no column without the Monte-Carlo step)."""


def _by_group(table: int) -> dict[str, dict[str, tuple[float, float]]]:
    """Table ``table`` (0: Table 2, 1: Table 3) as group -> method -> (mean, std)."""
    groups: dict[str, dict[str, tuple[float, float]]] = {"Sim.": {}, "Exp.": {}}
    for name, tables in PUBLISHED.items():
        figures = tables[table]
        if figures is not None:
            groups["Sim."][name] = (figures[0], figures[1])
            groups["Exp."][name] = (figures[2], figures[3])
    return groups


PAPER_MATCHING = _by_group(0)
"""Table 2 of the paper: mean and standard deviation of the matching index."""
PAPER_SECONDS = _by_group(1)
"""Table 3 of the paper: mean and standard deviation of the time, seconds."""
