"""The quasi-static dresser of generator 3.0.0 (the ground truth of the v4 retargeting
editions): a garment follows its body from the design body at rest to a subject in a pose.

The garment starts as designed, on its design body in the rest pose, and settles there
under gravity. The body then changes gradually, **shape first** (the phenotype blends from
the design subject's to the wearer's, rest pose), **then pose** (the joint rotations grow
from zero to the target's, on the wearer's shape); each intermediate body is one quasi-static
solve (:func:`dressmeup.data.synth.cloth.solve`) that starts from the previous state. The
cloth is moved only by the body's contact and by the anchors that hold its waistband or
shoulders to the body surface; nothing of it is carried by skinning or by a transfer of the
body's displacement (the anchors: :class:`dressmeup.data.synth.common.BodyAnchors`).

The number of intermediate bodies of a path is chosen so that no body vertex near the
garment moves more than ``body_step`` between two of them.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from dressmeup.data.synth.cloth import ClothModel, ClothSettings, Loads, solve
from dressmeup.data.synth.common import BodyAnchors


@dataclass(frozen=True)
class DressSettings:
    """Path and solver settings of :class:`Dresser` (SI units)."""

    body_step: float = 0.03  # m, largest body vertex move (near the garment) per path step
    near: float = 0.10  # m, body vertices this close to the garment count for body_step
    step_tolerance: float = 5e-2  # residual force ending an intermediate solve
    step_iterations: int = 10  # ... or this many iterations
    final_tolerance: float = 1e-3  # ... the last solve of a path (the written garment)
    # sensitivity checks only: every vertex of the designed garment moved this far (m) in a
    # random direction (seeded by start_seed) before it settles
    start_jitter: float = 0.0
    start_seed: int = 0
    cloth: ClothSettings = field(default_factory=ClothSettings)

    def to_dict(self) -> dict:
        """The settings as a JSON-able dict."""
        return asdict(self)

    @classmethod
    def from_dict(cls, overrides: dict) -> DressSettings:
        """The defaults with ``overrides`` (its ``"cloth"`` entry: overrides of
        :class:`ClothSettings`); unknown names raise ``ValueError`` naming them."""
        over = dict(overrides)
        cloth_over = dict(over.pop("cloth", {}) or {})
        known = {f for f in cls.__dataclass_fields__ if f != "cloth"}
        known_cloth = set(ClothSettings.__dataclass_fields__)
        bad = sorted(set(over) - known) + [f"cloth.{k}" for k in sorted(set(cloth_over)
                                                                          - known_cloth)]
        if bad:
            raise ValueError(f"dress settings: unknown {bad}; known {sorted(known)} and "
                             f"cloth.{sorted(known_cloth)}")
        return cls(**over, cloth=ClothSettings(**cloth_over))

    def longer(self, factor: float = 2.0) -> DressSettings:
        """The same path run ``factor`` times longer: ``factor`` times as many intermediate
        bodies, and every tolerance divided by ``factor``."""
        c = self.cloth
        cloth = ClothSettings(**{**c.to_dict(), "tolerance": c.tolerance / factor,
                                 "energy_tolerance": c.energy_tolerance / factor,
                                 "max_iterations": int(c.max_iterations * factor)})
        return DressSettings(body_step=self.body_step / factor, near=self.near,
                             step_tolerance=self.step_tolerance / factor,
                             step_iterations=int(self.step_iterations * factor),
                             final_tolerance=self.final_tolerance / factor,
                             start_jitter=self.start_jitter, start_seed=self.start_seed,
                             cloth=cloth)

    def start(self, rest_V: np.ndarray) -> np.ndarray:
        """The state a garment settles from: ``rest_V (n, 3)``, moved by ``start_jitter``."""
        if self.start_jitter <= 0:
            return np.asarray(rest_V, np.float64)
        u = np.random.default_rng([self.start_seed, 5]).normal(size=np.shape(rest_V))
        return rest_V + self.start_jitter * u / np.linalg.norm(u, axis=1, keepdims=True)


def path_bodies(body_at: Callable[[float], np.ndarray], start_V: np.ndarray,
                garment: np.ndarray, settings: DressSettings) -> list[np.ndarray]:
    """The intermediate bodies ``body_at(t)`` (``t`` in (0, 1], evenly spaced) of one path.

    Their number is the largest move of a body vertex within ``settings.near`` of the
    ``garment (n, 3)`` between ``start_V`` and ``body_at(1)``, divided by
    ``settings.body_step`` (rounded up, at least 1).
    """
    end = body_at(1.0)
    near = cKDTree(garment).query(start_V, distance_upper_bound=settings.near)[0] < np.inf
    move = np.linalg.norm(end - start_V, axis=1)[near]
    n = max(1, int(np.ceil((move.max() if len(move) else 0.0) / settings.body_step)))
    return [body_at(k / n) for k in range(1, n)] + [end]


class Dresser:
    """Moves one garment through body paths by quasi-static simulation.

    Parameters
    ----------
    rest_V : (n, 3) float64 the garment as designed (its rest shape, on the design body).
    faces : (m, 3) int64.
    anchors : where the garment holds on to the body.
    body_F : (c, 3) int64 faces of every body of the paths.
    up : (3,) unit vector opposite to gravity.
    settings : path and solver settings.
    """

    def __init__(self, rest_V: np.ndarray, faces: np.ndarray, anchors: BodyAnchors,
                 body_F: np.ndarray, up: np.ndarray, settings: DressSettings | None = None
                 ) -> None:
        self.settings = settings or DressSettings()
        self.model = ClothModel(rest_V, faces, self.settings.cloth)
        self.anchors, self.body_F = anchors, np.asarray(body_F, np.int64)
        self.up = np.asarray(up, np.float64) / np.linalg.norm(up)

    def follow(self, x: np.ndarray, bodies: list[np.ndarray]) -> tuple[np.ndarray, dict]:
        """Solve on every body of ``bodies`` in turn, each from the previous state; the
        last to ``final_tolerance``.

        Returns
        -------
        ``(vertices (n, 3), stats)``; stats: ``steps``, ``iterations`` (all solves),
        ``unconverged_steps``, the last solve's ``energy``, ``grad_norm``, ``grad_max``,
        ``energy_change``, ``converged``, ``self_pairs``, and ``cpu_s``.
        """
        s = self.settings
        t0 = time.process_time()
        iterations, unconverged, last = 0, 0, {}
        for k, body_V in enumerate(bodies):
            final = k == len(bodies) - 1
            loads = Loads(body_V, self.body_F, self.anchors.points(body_V),
                          self.anchors.weight, self.up)
            res = solve(self.model, x, loads,
                        tolerance=s.final_tolerance if final else s.step_tolerance,
                        max_iterations=None if final else s.step_iterations)
            x, last = res.vertices, res.stats
            iterations += last["iterations"]
            unconverged += not last["converged"]
        return x, {"steps": len(bodies), "iterations": iterations,
                   "unconverged_steps": unconverged, **{k: last[k] for k in (
                       "energy", "grad_norm", "grad_max", "energy_change", "converged",
                       "self_pairs")},
                   "cpu_s": time.process_time() - t0}
