"""How a garment follows its body: the skinning weights a garment takes from the body it is
made on (skirts and dresses move with the hips, not as trouser legs)."""

from __future__ import annotations

import numpy as np

from dressmeup.body.skinning import transfer_weights

SKIRT_LIKE = ("skirt", "dress")
LEG_TO_HIP = {"left_knee": "left_hip", "left_ankle": "left_hip", "left_foot": "left_hip",
              "right_knee": "right_hip", "right_ankle": "right_hip", "right_foot": "right_hip"}


def garment_weights(garment, body_V, body_F, body_W, joint_names, frame):
    """Skinning weights ``(n, j)`` of a garment (``.vertices``, ``.faces``, ``.garment_type``)
    transferred from a rest body (skirts and dresses: leg bones folded into the hips and
    blended towards the pelvis below them)."""
    W = transfer_weights(body_V, body_F, body_W, garment.vertices, faces=garment.faces,
                         smooth_iterations=10)
    if garment.garment_type in SKIRT_LIKE:
        # a skirt is not a pair of trouser legs: leg bones move it through the hips only,
        # and less so the further below the hips (the rest comes from the relaxation)
        idx = {n: k for k, n in enumerate(joint_names)}
        for leg, hip in LEG_TO_HIP.items():
            W[:, idx[hip]] += W[:, idx[leg]]
            W[:, idx[leg]] = 0.0
        J = frame.joints
        hip_h = 0.5 * (frame.h(J["left_hip"]) + frame.h(J["right_hip"]))
        beta = np.clip((hip_h - frame.h(garment.vertices)) / 0.3, 0.0, 0.6)[:, None]
        pel = np.zeros(W.shape[1])
        pel[idx["pelvis"]] = 1.0
        W = (1 - beta) * W + beta * pel
        W /= W.sum(1, keepdims=True)
    return W


