"""The paper's method as written (sections 3.1-3.3), selectable as ``method="paper"``.

:mod:`~merging.paper.sinogram`
    The sinogram of an occupancy grid, the Radon transform of eqs. (2)-(6).
:mod:`~merging.paper.method`
    Rotation from the sinograms' maxima (eq. 7), translation from the
    cross-correlations of their projections (eqs. 8-17), and the pipeline
    (:func:`paper_merge`).
:mod:`~merging.paper.monte_carlo`
    The search space of Gaussian mixtures (eqs. 18-26) and the Monte-Carlo
    optimisation over it (eqs. 27-30).

Importing this package registers the method with :func:`merging.estimate_transform`.
"""

from merging.paper.method import paper_merge

__all__ = ["paper_merge"]
