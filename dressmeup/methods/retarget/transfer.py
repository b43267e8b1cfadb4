"""``transfer``: carry the garment by the body's own displacement between the two posed bodies.

Every body of the model shares its topology, so a point of the source body's surface (a skin
face and barycentric coordinates) has its place on the target body; each garment vertex
moves by the displacement of its closest point on the source body
(:func:`dressmeup.data.synth.generator2.transfer_to_body`, the start of generator 2.x's fit to
another subject). One closest-point query, no weights, no learning: the simplest operator that
follows both shape and pose, and the reference a shortcut from the generator's operators must
not beat (tests/bench/test_bench_retarget_v4_shortcut.py).
"""

from __future__ import annotations

import numpy as np

from dressmeup.data.synth.generator2 import transfer_to_body
from dressmeup.methods.retarget.base import RetargetMethod, body_context, check_garment

__all__ = ["BodyTransfer"]


class BodyTransfer(RetargetMethod):
    """Move each garment vertex with the body surface at its closest point (module docstring).
    No hyperparameters."""

    name = "transfer"

    def retarget(self, garment_V, garment_F, source, target, body_model) -> np.ndarray:
        """See :mod:`dressmeup.methods.retarget.base`; returns (n, 3) float64."""
        V, _ = check_garment(garment_V, garment_F)
        s, t = body_context(body_model, source), body_context(body_model, target)
        return transfer_to_body(V, s.skin_vertices, t.skin_vertices, s.skin_faces)
