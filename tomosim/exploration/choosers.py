"""The target choosers by name: the rules a robot picks its frontier by.

A chooser turns a robot's candidates and what it knows of its teammates
(:mod:`~tomosim.exploration.targets`) into one target cell. Choosers are
selected by name (:data:`CHOOSERS`, :func:`make_chooser`):

``nearest``
    The cheapest cluster to reach, less a bonus for its size; teammates are
    ignored (every robot explores as if alone).
``utility``
    Burgard et al.'s coordination [1]_ (:mod:`~tomosim.exploration.utility`):
    a frontier cell's utility drops around the targets teammates have taken.
``assignment``
    Robots to clusters by path cost, the Hungarian method
    (:mod:`~tomosim.exploration.assignment`).

Every chooser scores the same way when a robot is alone, so with no links
the three give the same episode.

References
----------
.. [1] W. Burgard, M. Moors, C. Stachniss, F. E. Schneider, "Coordinated
   multi-robot exploration", IEEE Transactions on Robotics 21(3), 376-386, 2005.
"""

from __future__ import annotations

from collections.abc import Callable

from tomosim.exploration.assignment import AssignmentChooser
from tomosim.exploration.nearest import NearestChooser
from tomosim.exploration.targets import TargetChooser
from tomosim.exploration.utility import UtilityChooser


def chooser_names() -> tuple[str, ...]:
    """Names :func:`make_chooser` accepts."""
    return tuple(CHOOSERS)


def make_chooser(name: str) -> TargetChooser:
    """The chooser called ``name``, with its default settings.

    Raises
    ------
    ValueError
        For an unknown name (the message lists the known ones).
    """
    factory = CHOOSERS.get(name)
    if factory is None:
        raise ValueError(
            f"unknown exploration policy {name!r}; choose one of: {', '.join(CHOOSERS)}"
        )
    return factory()


CHOOSERS: dict[str, Callable[[], TargetChooser]] = {
    "nearest": NearestChooser,
    "utility": UtilityChooser,
    "assignment": AssignmentChooser,
}
"""Every chooser by name."""
