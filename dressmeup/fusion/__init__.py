"""Fusion of capture sessions into scans (docs/fusion.md).

- :mod:`~dressmeup.fusion.pipeline`: ``fuse_session`` / ``fuse_frames`` -> ``FusionResult``,
  ``save_scan`` / ``load_scan``, ``FusionConfig``.
- :mod:`~dressmeup.fusion.filtering`: undistortion, range, flying pixels, bilateral smoothing.
- :mod:`~dressmeup.fusion.icp`: multiway ICP + pose graph extrinsic refinement.
- :mod:`~dressmeup.fusion.tsdf`: open3d ``VoxelBlockGrid`` TSDF fusion (CPU or CUDA).
- :mod:`~dressmeup.fusion.cleanup`: pymeshlab cleanup, decimation, screened Poisson.
- :mod:`~dressmeup.fusion.evaluate`: scores against a synthetic session's ground truth.
"""
