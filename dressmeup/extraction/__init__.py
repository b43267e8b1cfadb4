"""Garments out of fused scans (docs/fusion.md).

- :mod:`~dressmeup.extraction.pipeline`: ``extract_garments`` (labels -> cut-out -> UV ->
  texture) and ``save_garment`` (OBJ + MTL + PNG).
- :mod:`~dressmeup.extraction.labels`: visibility-aware label voting, graph smoothing,
  island cleanup, the colour fallback.
- :mod:`~dressmeup.extraction.cutout`: garment cut-out with clean boundaries.
- :mod:`~dressmeup.extraction.texture`: xatlas atlas and best-view texture baking.
"""
