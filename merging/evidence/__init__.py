"""The evidence that judges a placement of map 2 on map 1, shared by every method.

A method proposes placements; these modules decide how well a placement is
supported and whether the merger vouches for it:

=======================================  ==============================================
module                                   what it holds
=======================================  ==============================================
:mod:`~merging.evidence.verify`          both maps' walls carried into each other: the
                                         fit, support and conflict of a placement, and
                                         the confidence they give
:mod:`~merging.evidence.blur`            a Gaussian blur spread from sparse wall cells
:mod:`~merging.evidence.refine`          sub-cell, sub-degree refinement by Gauss-Newton
:mod:`~merging.evidence.refine_kernels`  the refinement's compiled inner loops
:mod:`~merging.evidence.robust`          evidence for maps that bend: walls met within a
                                         tolerance, open space that agrees
:mod:`~merging.evidence.mirror`          evidence that looks the same in a mirror image
:mod:`~merging.evidence.pinning`         what sliding a placement a few cells costs:
                                         whether it is pinned down
:mod:`~merging.evidence.verdict`         the verdict on the best placement, and in words
                                         why it is refused
=======================================  ==============================================
"""
