"""dressmeup: 3D garment datasets and benchmarks.

The package is split by the stages of the data's journey (see docs/architecture.md)::

    geometry, metrics            low-level, import nothing above them
    io, body                     file formats, body models and registration
    capture, fusion, extraction  multi-view RGBD -> fused scan -> garments
    data                         dataset layout, manifest, loaders, synthetic generator
    methods                      reference baselines (retargeting, UV parameterisation)
    bench                        editions, submissions, scoring, leaderboards
    viz                          headless pictures
    cli                          the ``dressmeup`` command (imports everything, imported by nothing)
"""

__version__ = "0.1.0"

__all__ = ["__version__"]
