"""From pairs to a team: linking N grids through their pairwise transforms, and fusing them.

:mod:`~merging.linking.forest`
    Pairwise estimates, the consistent spanning forest over them and one frame
    per group (:func:`link_maps`, :func:`merge_all`).
:mod:`~merging.linking.across`
    Checking a pair that joins two linked groups on the maps across the join.
:mod:`~merging.linking.posegraph`
    Placing a group by all of its pairwise transforms at once.
:mod:`~merging.linking.fusion`
    Fusing grids once their transforms are known (:func:`fuse`, :func:`merge`).
"""

from merging.linking.forest import Linking, MergeAllResult, link_maps, merge_all
from merging.linking.fusion import FusedMap, fuse, merge

__all__ = ["FusedMap", "Linking", "MergeAllResult", "fuse", "link_maps", "merge", "merge_all"]
