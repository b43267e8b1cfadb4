"""The defined motion of generator 4: how a garment's body gets from its design body at rest
to a target body in a target pose, frame by frame.

A motion has four phases at a fixed time step ``dt`` (seconds):

1. ``rest_frames``: the design body at rest holds still while the garment, as designed,
   falls onto it and settles;
2. ``shape_frames``: the phenotype blends from the design subject's to the target's (rest
   pose);
3. ``pose_frames``: every joint's rotation grows from zero to the target's (the axis-angle
   vector of each joint scaled by the phase's progress: the rotation about a fixed axis, so
   each joint turns at its own rate), on the target's shape;
4. ``settle_frames``: the target body holds still.

Progress within phases 2 and 3 follows the smoothstep ``3 t^2 - 2 t^3`` of the frame's time
(``t = k / frames``), so the body starts and stops each phase at rest. Between two frames
the body moves linearly (the collision handling of :mod:`dressmeup.data.synth.dynamics`
relies on that). The motion is part of an edition's definition: it is written in the
edition's generator parameters and in every sample's statistics, and with the same
bodies and poses the same frames come out.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass

import numpy as np

from dressmeup.errors import InputError
from dressmeup.hyperparameters import resolve_config


@dataclass(frozen=True)
class MotionSpec:
    """Frames and time step of a motion (module docstring); times in seconds."""

    dt: float = 1.0 / 30.0
    rest_frames: int = 20
    shape_frames: int = 30
    pose_frames: int = 45
    settle_frames: int = 30

    def __post_init__(self) -> None:
        if not (np.isfinite(self.dt) and 0 < self.dt <= 0.1):
            raise InputError(f"motion.dt: expected a time step in (0, 0.1] s, got {self.dt!r}")
        for name in ("rest_frames", "shape_frames", "pose_frames", "settle_frames"):
            v = getattr(self, name)
            if not isinstance(v, (int, np.integer)) or isinstance(v, bool) or not 0 <= v <= 10000:
                raise InputError(f"motion.{name}: expected an integer in 0..10000, got {v!r}")
        if self.pose_frames < 1:
            raise InputError("motion.pose_frames: expected at least 1 frame")

    @property
    def frames(self) -> int:
        """Frames after the start (the start itself is frame 0)."""
        return self.rest_frames + self.shape_frames + self.pose_frames + self.settle_frames

    @property
    def duration(self) -> float:
        """Length of the motion, seconds."""
        return self.frames * self.dt

    def refined(self, factor: int = 2) -> MotionSpec:
        """The same motion (same phase durations) at ``dt / factor``: the time-step
        sensitivity check."""
        f = int(factor)
        return MotionSpec(dt=self.dt / f, rest_frames=self.rest_frames * f,
                          shape_frames=self.shape_frames * f, pose_frames=self.pose_frames * f,
                          settle_frames=self.settle_frames * f)

    def to_dict(self) -> dict:
        """The spec as a JSON-able dict."""
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict | None) -> MotionSpec:
        """The defaults with the entries of ``d``; an unknown entry or a value of the wrong
        type raises ``InputError`` (:func:`dressmeup.hyperparameters.resolve_config`)."""
        return resolve_config({"default": cls()}, "default", dict(d or {}), "motion")


def smoothstep(t: float) -> float:
    """``3 t^2 - 2 t^3`` of ``t`` clipped to [0, 1]."""
    t = min(max(float(t), 0.0), 1.0)
    return t * t * (3.0 - 2.0 * t)


@dataclass(frozen=True)
class BodyState:
    """Where the body is at one frame: phenotype ``shape (s,)`` and joint rotations ``pose
    (j, 3)`` (axis-angle, radians), and the phase it belongs to."""

    shape: np.ndarray
    pose: np.ndarray
    phase: str


def body_states(spec: MotionSpec, design_shape: np.ndarray, target_shape: np.ndarray,
                target_pose: np.ndarray) -> list[BodyState]:
    """The body of every frame ``0 .. spec.frames`` of the motion (module docstring).

    Parameters
    ----------
    spec : the motion.
    design_shape : (s,) float64 phenotype of the garment's design body.
    target_shape : (s,) float64 phenotype of the target body.
    target_pose : (j, 3) float64 axis-angle joint rotations of the target pose.

    Returns
    -------
    ``spec.frames + 1`` states; frame 0 is the design body at rest.
    """
    a = np.asarray(design_shape, np.float64)
    b = np.asarray(target_shape, np.float64)
    q = np.asarray(target_pose, np.float64)
    zero = np.zeros_like(q)
    out = [BodyState(a, zero, "start")]
    out += [BodyState(a, zero, "rest")] * spec.rest_frames
    for k in range(1, spec.shape_frames + 1):
        s = smoothstep(k / spec.shape_frames)
        out.append(BodyState((1.0 - s) * a + s * b, zero, "shape"))
    for k in range(1, spec.pose_frames + 1):
        out.append(BodyState(b, smoothstep(k / spec.pose_frames) * q, "pose"))
    out += [BodyState(b, q, "settle")] * spec.settle_frames
    return out


def frame_bodies(states: list[BodyState], body_at: Callable[[np.ndarray, np.ndarray],
                                                               np.ndarray]) -> list[np.ndarray]:
    """The body surface ``(b, 3)`` of every state, computed once per distinct state (frames
    where the body holds still share one array)."""
    out: list[np.ndarray] = []
    last: tuple | None = None
    for st in states:
        key = (st.shape.tobytes(), st.pose.tobytes())
        if key != last:
            current = np.asarray(body_at(st.shape, st.pose), np.float64)
            last = key
        out.append(current)
    return out
