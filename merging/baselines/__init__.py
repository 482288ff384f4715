"""The baselines of the paper's comparison (its Tables 2 and 3), behind the merger contract.

Each is a registered method of :func:`merging.estimate_transform`, with the
same result type, conventions and bad-input behaviour as the default:

========================  ==================================================
``method=``               what it is (the paper's name)
========================  ==================================================
``"spectral"``            Carpin's Hough-spectrum merger (SMM),
                          :mod:`merging.baselines.spectral`
``"sift"``                SIFT features + RANSAC, in place of SURF,
                          :mod:`merging.baselines.features`
``"harris"``              Harris corners + oriented patches + RANSAC (HCD)
``"shi_tomasi"``          minimum-eigenvalue corners + patches + RANSAC (MEV)
``"orb"``                 ORB features + RANSAC (not in the paper)
``"registration"``        Fourier (log-polar + phase correlation) image
                          registration (REG), :mod:`merging.baselines.registration`
``"ros_akaze"``,          the ROS ``multirobot_map_merge`` pipeline (OpenCV
``"ros_orb"``             AKAZE or ORB, ``estimateAffinePartial2D``), with
                          its own acceptance rule; needs the ``opencv``
                          extra, :mod:`merging.baselines.ros`
========================  ==================================================

The paper's baselines have no acceptance test; here each one's
``confidence`` and ``accepted`` come from the shared verification
(:func:`merging.baselines.common.verdict`), so that "accepted" means the
same for every method. The rigid RANSAC fit is :mod:`merging.baselines.ransac`.
"""
