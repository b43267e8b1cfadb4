"""``simulate``: carry the garment from the source body to the target by cloth dynamics.

The source body's shape, pose and translation turn into the target's over a timed motion
(``shape_frames`` blending the shape, then ``pose_frames`` turning every joint's axis-angle
vector linearly from the source's to the target's, each phase eased by the smoothstep, then
``settle_frames`` holding still, at ``dt`` seconds a frame), and the garment follows it by
generator 4's dynamics (:class:`dressmeup.data.synth.dynamics.ClothDynamics`: implicit time
steps, springs, gravity, barrier contact with the body and itself, so no state penetrates).
The garment's rest shape is the source garment as given (its design is not known); the top
``anchor_share`` of its height is held to the body as a waistband or shoulders would be;
the pinch rule of the contact (body parts pressed together leave it) measures the parts'
distance at the source body as posed, not at rest.
A motion the dynamics cannot follow (cloth caught between body parts, over the sub-step
budget of :class:`~dressmeup.data.synth.dynamics.DynamicsSettings`) falls back to ``transfer``'s result.

This is the operator of the generator applied to public inputs: the reference a shortcut
through the generator must not beat (tests/bench/test_bench_retarget_v5_shortcut.py), and a
physics baseline. It costs seconds to minutes of CPU a pair (tens of seconds on 35 mm anny
garments), far more than the other baselines.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from dressmeup.data.synth.common import BodyAnchors
from dressmeup.data.synth.dynamics import ClothDynamics, DynamicsSettings, simulate
from dressmeup.data.synth.garments import BodyFrame
from dressmeup.data.synth.generator2 import transfer_to_body
from dressmeup.data.synth.motion import smoothstep
from dressmeup.methods.retarget.base import RetargetMethod, body_context, check_garment

__all__ = ["SimulateRetarget"]


class SimulateRetarget(RetargetMethod):
    """Cloth dynamics along a motion from the source body to the target (module docstring).

    Parameters
    ----------
    shape_frames, pose_frames, settle_frames : frames of the motion's phases.
    dt : s, time step of a frame.
    anchor_share : share of the garment's height, from its top, held to the body.
    anchor_gap : m, anchors sit this far outside the body surface.
    """

    name = "simulate"

    def __init__(self, shape_frames: int = 20, pose_frames: int = 30, settle_frames: int = 15,
                 dt: float = 1.0 / 30.0, anchor_share: float = 0.1,
                 anchor_gap: float = 0.003) -> None:
        self.shape_frames = shape_frames
        self.pose_frames = pose_frames
        self.settle_frames = settle_frames
        self.dt = dt
        self.anchor_share = anchor_share
        self.anchor_gap = anchor_gap

    def path(self, source, target) -> list:
        """The body parameters (:class:`~dressmeup.body.BodyParams`) of every frame, the
        source's first."""
        s0, s1 = np.asarray(source.shape, np.float64), np.asarray(target.shape, np.float64)
        q0, q1 = np.asarray(source.pose, np.float64), np.asarray(target.pose, np.float64)
        t0, t1 = np.asarray(source.transl, np.float64), np.asarray(target.transl, np.float64)
        out = [source]
        for k in range(1, self.shape_frames + 1):
            w = smoothstep(k / self.shape_frames)
            out.append(dataclasses.replace(source, shape=(1 - w) * s0 + w * s1))
        for k in range(1, self.pose_frames + 1):
            w = smoothstep(k / self.pose_frames)
            out.append(dataclasses.replace(target, pose=(1 - w) * q0 + w * q1,
                                           transl=(1 - w) * t0 + w * t1))
        return out + [target] * self.settle_frames

    def retarget(self, garment_V, garment_F, source, target, body_model) -> np.ndarray:
        """See :mod:`dressmeup.methods.retarget.base`; returns (n, 3) float64."""
        V, F = check_garment(garment_V, garment_F)
        bodies, last = [], None
        for p in self.path(source, target):
            if p is not last:
                ctx = body_context(body_model, p)
                last = p
            bodies.append(ctx.skin_vertices)
        faces = ctx.skin_faces
        rest = body_model.posed(body_model.default_params())
        up = BodyFrame.from_joints(np.asarray(rest.rest_joints),
                                   tuple(body_model.joint_names)).up
        height = V @ up
        top = (height >= np.quantile(height, 1.0 - self.anchor_share)).astype(np.float64)
        anchors = BodyAnchors(V, top, bodies[0], faces, gap=self.anchor_gap)
        dyn = ClothDynamics(V, F, faces, up, DynamicsSettings(), anchor_weight=top,
                            body_rest=bodies[0])
        try:
            x, _ = simulate(dyn, V, bodies, self.dt, anchors.points)
        except RuntimeError:  # the dynamics cannot follow the motion: transfer's result
            return transfer_to_body(V, bodies[0], bodies[-1], faces)
        return x
