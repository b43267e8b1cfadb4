"""Fusion of capture sessions into scans (docs/fusion.md).

- :mod:`~dressmeup.fusion.pipeline`: ``fuse_session`` / ``fuse_frames`` -> ``FusionResult``,
  ``save_scan`` / ``load_scan``, ``FusionConfig``.
- :mod:`~dressmeup.fusion.filtering`: undistortion, range, flying pixels, bilateral smoothing.
- :mod:`~dressmeup.fusion.icp`: multiway ICP (pairwise multi-scale registration + pose graph).
- :mod:`~dressmeup.fusion.refine`: refinement that keeps a camera's new pose only where it
  lowers view-to-view residuals, within bounds.
- :mod:`~dressmeup.fusion.consistency`: each camera's depth against the other cameras' (a
  camera with wrong intrinsics or pose is named).
- :mod:`~dressmeup.fusion.tsdf`: open3d ``VoxelBlockGrid`` TSDF fusion (CPU or CUDA).
- :mod:`~dressmeup.fusion.cleanup`: mesh repair (numpy), decimation and screened Poisson (pymeshlab).
- :mod:`~dressmeup.fusion.evaluate`: scores against a synthetic session's ground truth, and
  Open3D's own integration of the same frames (the reference of benchmarks/perf/fusion_real.py).
"""
