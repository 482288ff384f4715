"""Compiled numerical kernels of the simulator's per-step work (numba).

Each kernel does in one compiled loop what a numpy function elsewhere in
``tomosim`` (or a scipy one) states in array operations; that function stays
as the readable specification and as the oracle the tests compare the kernel
with (``tests/tomosim/kernels/test_kernels.py``). Kernel, then oracle:

- :func:`~tomosim.kernels.raycast.cast_scan`: :func:`tomosim.ray_geometry.cast_segments`
  and :func:`tomosim.ray_geometry.cast_circles` (in turn checked against pymunk's
  segment queries);
- :func:`~tomosim.kernels.raycast.scan_team`: :func:`~tomosim.kernels.raycast.cast_scan`
  and :func:`~tomosim.kernels.raycast.add_noise` robot by robot
  (:meth:`tomosim.lidar.Lidar.scan`);
- :func:`~tomosim.kernels.logodds.integrate_scan`: :func:`tomosim.mapping.integrate_rays`
  and :func:`tomosim.mapping.ros_codes`; it does the work of
  :func:`~tomosim.kernels.logodds.update_grid`;
- :func:`~tomosim.kernels.reveal.reveal_team`: the evaluation rule of
  :func:`tomosim.evaluation.known_in_world`;
- :func:`~tomosim.kernels.crop.crop_max_pool`: window slicing and a reshaped maximum
  in numpy;
- :func:`~tomosim.kernels.overlap.shared_free`: :func:`tomosim.team.quality.shared_free_numpy`;
- :func:`~tomosim.kernels.planning.block_states`:
  :func:`tomosim.exploration.frontiers.coarsen`;
- :func:`~tomosim.kernels.planning.distances_to_walls`:
  ``scipy.ndimage.distance_transform_edt``;
- :func:`~tomosim.kernels.planning.frontier_groups`:
  :func:`tomosim.exploration.frontiers.frontier_clusters`.

The modules here import neither pymunk, PettingZoo nor rerun, and nothing of
``tomosim`` but each other.
"""
