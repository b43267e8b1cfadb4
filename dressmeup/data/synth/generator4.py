"""Generator 4: each garment dressed by a defined motion simulated in time (the ground truth
of the v5 retargeting editions).

A sample is the end of one motion (:mod:`dressmeup.data.synth.motion`): the garment, as
designed on its design body at rest, settles there, the body's shape blends into the
target's, the pose grows into the target pose, and the body holds still while the cloth
settles, all in frames of a fixed time step simulated by
:mod:`dressmeup.data.synth.dynamics` (backward Euler with damping, IPC barrier contact with
the body and between cloth layers, continuous collision detection). The written garment is
the cloth at the motion's last frame; the motion, the settings and the solver's figures of
every frame are in the sample's statistics, so the sample can be replayed.

Anchors: the garment's supported vertices (waistband, shoulders) are tied to their closest
point on the design body, ``anchor_gap`` outside it along the body's normal, and that point
moves with the body (an elastic band's grip).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from dressmeup.body import BodyParams, get_body_model
from dressmeup.data.synth.common import (
    BODY_DECIMALS,
    STORE_DECIMALS,
    BodyAnchors,
    drape_stats,
    quantize,
)
from dressmeup.data.synth.dynamics import ClothDynamics, DynamicsSettings, simulate
from dressmeup.data.synth.garments import BodyFrame, build_garment, welded
from dressmeup.data.synth.motion import MotionSpec, body_states, frame_bodies

VERSION = "4.0.0"


class SimulationFailed(RuntimeError):
    """A motion the cloth could not follow: the collision-free sub-steps ran out (the body's
    move squeezes the cloth between body parts, or into a gap thinner than the contact
    distance). Deterministic for the same inputs: a dataset records the target as failed."""


@dataclass(frozen=True)
class Gen4Settings:
    """Everything a generator-4 sample depends on besides its garment and bodies."""

    motion: MotionSpec = field(default_factory=MotionSpec)
    dynamics: DynamicsSettings = field(default_factory=DynamicsSettings)
    edge_length: float = 0.015  # m, garment edge length
    anchor_gap: float = 0.003  # m, anchors sit this far outside the body surface

    def to_dict(self) -> dict:
        """The settings as a JSON-able dict."""
        return asdict(self)


@dataclass(frozen=True)
class BodyKit:
    """One body model's surface, ready for dressing.

    Attributes
    ----------
    model : the :class:`~dressmeup.body.BodyModel`.
    keep : (b,) int64 vertex ids of the skin (the largest connected component).
    faces : (c, 3) int64 skin faces (indices into ``keep``).
    joint_names : the model's joint names.
    labels : (b,) names of the dominant joint of each skin vertex.
    """

    model: Any
    keep: np.ndarray
    faces: np.ndarray
    joint_names: tuple[str, ...]
    labels: np.ndarray

    def surface(self, shape: np.ndarray, pose: np.ndarray) -> np.ndarray:
        """Skin vertices ``(b, 3) float64`` of phenotype ``shape (s,)`` in ``pose (j, 3)``,
        rounded to 1e-9 m."""
        out = self.model.posed(BodyParams(model=self.model.name, shape=shape, pose=pose))
        return quantize(np.asarray(out.vertices)[self.keep], BODY_DECIMALS)

    def rest(self, shape: np.ndarray) -> tuple[np.ndarray, BodyFrame]:
        """The rest body of ``shape``: skin vertices ``(b, 3)`` and its frame."""
        zero = np.zeros((len(self.joint_names), 3))
        out = self.model.posed(BodyParams(model=self.model.name, shape=shape, pose=zero))
        joints = quantize(np.asarray(out.rest_joints), BODY_DECIMALS)
        return (quantize(np.asarray(out.rest_vertices)[self.keep], BODY_DECIMALS),
                BodyFrame.from_joints(joints, self.joint_names))


def load_body_kit(body_model: str = "anny") -> BodyKit:
    """The :class:`BodyKit` of a body model (``anny`` or ``procedural``)."""
    model = get_body_model(body_model)
    keep, faces = model.skin()
    names = tuple(model.joint_names)
    weights = np.asarray(model.skinning_weights)[keep]
    return BodyKit(model, np.asarray(keep, np.int64), np.asarray(faces, np.int64), names,
                   np.array(names)[weights.argmax(1)])


@dataclass(frozen=True)
class BuiltGarment:
    """A garment as designed on its design body at rest (vertices welded, 1 µm grid).

    Attributes
    ----------
    garment_type, category : names from the type table.
    vertices : (n, 3) float64; faces : (m, 3) int64.
    uv : (k, 2) float64 and uv_faces : (m, 3) int64 or None.
    support : (n,) float64 in [0, 1], anchor strength per vertex.
    design_shape : (s,) float64 phenotype of the design body.
    frame : the design body's :class:`BodyFrame` at rest (up, left, forward, joints).
    """

    garment_type: str
    category: str
    vertices: np.ndarray
    faces: np.ndarray
    uv: np.ndarray | None
    uv_faces: np.ndarray | None
    support: np.ndarray
    design_shape: np.ndarray
    frame: BodyFrame


def build(kit: BodyKit, garment_type: str, params: dict, design_shape: np.ndarray,
          edge_length: float) -> BuiltGarment:
    """Build one parametric garment on the rest body of ``design_shape``."""
    body_V, frame = kit.rest(np.asarray(design_shape, np.float64))
    g = build_garment(garment_type, params, body_V, kit.faces, kit.labels, frame,
                      edge_length=edge_length)
    V0, F, uv_faces, support = welded(g, quantize(g.vertices, STORE_DECIMALS))
    return BuiltGarment(g.garment_type, g.category, V0, F, g.uv, uv_faces, support,
                        np.asarray(design_shape, np.float64), frame)


@dataclass
class DressedSample:
    """The end of one motion: garment ``vertices (n, 3)`` (1 µm grid), the target body's
    skin ``body_vertices (b, 3)`` and the sample's statistics."""

    vertices: np.ndarray
    body_vertices: np.ndarray
    stats: dict


def motion_frames(kit: BodyKit, garment: BuiltGarment, target_shape: np.ndarray,
                  target_pose: np.ndarray, settings: Gen4Settings
                  ) -> tuple[list[np.ndarray], BodyAnchors]:
    """The body surface ``(b, 3)`` of every frame of the motion :func:`dress` simulates
    (``settings.motion.frames + 1``, the design body at rest first) and the garment's anchors
    (:class:`~dressmeup.data.synth.common.BodyAnchors` on the first)."""
    states = body_states(settings.motion, garment.design_shape, target_shape, target_pose)
    bodies = frame_bodies(states, kit.surface)
    return bodies, BodyAnchors(garment.vertices, garment.support, bodies[0], kit.faces,
                               gap=settings.anchor_gap)


def dress(kit: BodyKit, garment: BuiltGarment, target_shape: np.ndarray,
          target_pose: np.ndarray, settings: Gen4Settings | None = None,
          on_frame: Callable[[int, np.ndarray, dict], None] | None = None) -> DressedSample:
    """Simulate the motion from the garment's design body at rest to ``target_shape (s,)``
    in ``target_pose (j, 3)`` (module docstring).

    Returns
    -------
    DressedSample; stats: ``generator``, ``motion``, ``dynamics`` (settings), per-frame
    solver figures (``frames``, ``substeps``, ``iterations``, ``unconverged_frames``,
    ``worst_residual``, ``max_iterations``), ``intersection_free`` (ipctk's exact check of
    cloth against body and itself at the end), the plausibility figures of
    :func:`dressmeup.data.synth.common.drape_stats` and ``cpu_s``.

    Raises
    ------
    SimulationFailed
        The motion needs more than ``settings.dynamics.substep_budget`` sub-steps a frame on
        average,
        or the dynamics cannot follow the body (:meth:`ClothDynamics.advance`).
    """
    s = settings or Gen4Settings()
    t0 = time.process_time()
    bodies, anchors = motion_frames(kit, garment, target_shape, target_pose, s)
    dyn = ClothDynamics(garment.vertices, garment.faces, kit.faces, garment.frame.up, s.dynamics,
                        anchor_weight=garment.support, body_rest=bodies[0])
    try:
        x, sim = simulate(dyn, garment.vertices, bodies, s.motion.dt, anchors.points, on_frame)
    except RuntimeError as exc:  # over the sub-step budget, or the dynamics' own stall
        raise SimulationFailed(str(exc)) from exc
    V = quantize(x, STORE_DECIMALS)
    stats = {"generator": VERSION, "motion": s.motion.to_dict(),
             "dynamics": s.dynamics.to_dict(), "anchor_gap": s.anchor_gap,
             **{k: v for k, v in sim.items() if k != "cpu_s"},
             "intersection_free": bool(dyn.intersection_free(V, bodies[-1])),
             **drape_stats(V, garment.faces, garment.vertices, bodies[-1], kit.faces),
             "cpu_s": time.process_time() - t0}
    return DressedSample(V, bodies[-1], stats)
