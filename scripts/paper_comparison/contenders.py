"""The columns of the tables: which registered methods run, under which names.

Each :class:`Contender` is one method of :func:`merging.estimate_transform`
with fixed options, labelled as here and as in the paper; :data:`FAMILIES`
groups the methods that share their machinery, for the halmstad references.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True, slots=True)
class Contender:
    """One column of the tables: a registered method with fixed options."""

    key: str
    method: str
    label: str
    paper_label: str
    options: tuple[tuple[str, Any], ...] = ()


CONTENDERS = (
    Contender("tomographic", "tomographic", "tomographic (default)", ""),
    Contender("paper", "paper", "paper", "Proposed"),
    Contender("paper_no_mco", "paper", "paper w/o MCO", "Proposed w/o MCO", (("optimise", False),)),
    Contender("spectral", "spectral", "spectral", "SMM"),
    Contender("sift", "sift", "SIFT", "SURF"),
    Contender("harris", "harris", "Harris", "HCD"),
    Contender("shi_tomasi", "shi_tomasi", "Shi-Tomasi", "MEV"),
    Contender("orb", "orb", "ORB", ""),
    Contender("registration", "registration", "registration", "REG"),
)
"""Columns in table order; ``paper_label`` is the paper's name for the same method."""
DEFAULT_KEY = "tomographic"
"""The column the others are compared with: the package's default method."""
FAMILIES = {
    "tomographic": "tomographic",
    "paper": "paper",
    "paper_no_mco": "paper",
    "spectral": "spectral",
    "sift": "features",
    "harris": "features",
    "shi_tomasi": "features",
    "orb": "features",
    "registration": "registration",
}
"""Methods sharing their machinery: agreement within a family corroborates nothing."""
