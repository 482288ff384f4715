"""The default method, ``method="tomographic"``: the paper's ideas, made robust and fast.

:mod:`~merging.tomographic.angular`
    Rotation hypotheses from angular spectra: the sinogram's columns through
    the Fourier slice theorem.
:mod:`~merging.tomographic.correlate`
    Translation hypotheses from the correlation of every projection at once.
:mod:`~merging.tomographic.search`
    The method itself (:func:`tomographic_merge`): its steps, and where each
    equation of the paper went.
:mod:`~merging.tomographic.candidates`
    What every step shares: both prepared maps and the ranked candidates.
:mod:`~merging.tomographic.hypotheses`
    Steps 1-4: rotations, translations, screening and refinement into a pool.
:mod:`~merging.tomographic.judging`
    Steps 5-6: the verdict on the pool, the mirror check.
:mod:`~merging.tomographic.restarts`
    Second looks at a placement: the refinement restarted from it moved.
:mod:`~merging.tomographic.tracking`
    Following a known transform between two growing maps (:func:`track_transform`).

The placement is judged by :mod:`merging.evidence`. Importing this package
registers the method with :func:`merging.estimate_transform`.
"""

from merging.tomographic.search import tomographic_merge
from merging.tomographic.tracking import track_transform

__all__ = ["tomographic_merge", "track_transform"]
