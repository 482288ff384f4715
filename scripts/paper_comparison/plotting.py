"""Access to matplotlib, the optional plotting dependency, and how figures are saved.

matplotlib is imported only when a figure is drawn; when it is missing the
script stops with the command that installs it.
"""

from __future__ import annotations

from pathlib import Path
from types import ModuleType
from typing import Any

PLOT_INSTALL = 'pip install "tomosim[plot]"'
"""How to install the plotting dependency."""
FIGURE_DPI = 80
"""Resolution of the PNG figures: small files that still read on a screen."""


def pyplot() -> ModuleType:
    """``matplotlib.pyplot`` on the non-interactive Agg backend.

    Raises
    ------
    SystemExit
        When matplotlib is not installed, naming :data:`PLOT_INSTALL`.
    """
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as error:  # pragma: no cover - depends on the environment
        raise SystemExit(f"plotting needs matplotlib: {PLOT_INSTALL}") from error
    return plt


def save(figure: Any, path: Path) -> None:
    """Lay out ``figure``, write it to ``path`` as PNG at :data:`FIGURE_DPI` and close it."""
    figure.tight_layout()
    figure.savefig(path, dpi=FIGURE_DPI)
    pyplot().close(figure)
