"""Study: generator 4 with the body's move inside the Newton solve (an IPC-style kinematic
collider), tried on one gallery target; not part of the toolkit. Record:
benchmarks/results/studies/2026-12-05-v5-resolution-and-cost.md.

Where a frame's carried joint move collides, instead of splitting the frame into sub-steps,
the scene's body vertices become unknowns pulled to their frame-end positions by a stiff
quadratic penalty (``--kmul`` times the largest cloth inertia weight); cloth and body move
together under the barrier and the CCD line search (at most 80 Newton iterations), and when
the body ends within ``--gap`` of its target and the last move to it is free, one ordinary
solve with the body there finishes the frame; otherwise the frame falls back to sub-steps.

    python benchmarks/studies/generator4_kinematic_prototype.py S005-G004-P003 --kmul 1e8
    python benchmarks/studies/generator4_kinematic_prototype.py S005-G004-P003 --kmul 1e8 \
        --dynamics '{"pinch": 0.02}'
    python benchmarks/studies/generator4_kinematic_prototype.py S008-G005-P007 --baseline

Targets are those of ``benchmarks/studies/generator4_gallery.py`` (``SUBJECT-GARMENT-POSE``).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from pathlib import Path

import numpy as np

MAX_ITERATIONS = 80


def install(kmul: float, gap: float, stats: dict) -> None:
    """Replace ``ClothDynamics.advance`` by the kinematic variant (module docstring)."""
    # heavy: ipctk, scipy.sparse (only this study uses them this way)
    import ipctk
    import scipy.sparse as sp

    from dressmeup.data.synth import dynamics as D
    from dressmeup.data.synth.cloth import factor, pcg

    plain = D.ClothDynamics.advance

    def stacked_free(scene, y0, b0, y1, b1) -> float:
        return float(ipctk.compute_collision_free_stepsize(
            scene.mesh, np.vstack([y0, b0]), np.vstack([y1, b1]), narrow_phase_ccd=D._CCD))

    def system(dyn, scene, y, b, c, z, anchors, b_to, K):
        """Potential, gradient and Hessian over cloth and body vertices."""
        e, g, Hc = dyn.smooth_system(y, c, z, anchors)
        H = sp.block_diag([Hc, sp.identity(3 * len(b), format="csc") * K], format="csc")
        db = b - b_to
        e += 0.5 * K * np.sum(db * db)
        grad = np.concatenate([g.ravel(), (K * db).ravel()])
        V = np.vstack([y, b])
        col = ipctk.NormalCollisions()
        col.build(scene.mesh, V, dyn.settings.dhat)
        if not col.empty():
            e += float(dyn.barrier(col, scene.mesh, V))
            grad = grad + np.asarray(dyn.barrier.gradient(col, scene.mesh, V))
            H = H + sp.csc_matrix(dyn.barrier.hessian(col, scene.mesh, V,
                                                      ipctk.PSDProjectionMethod.CLAMP))
        return float(e), grad, H.tocsc()

    def energy(dyn, scene, y, b, c, z, anchors, b_to, K) -> float:
        V = np.vstack([y, b])
        col = ipctk.NormalCollisions()
        col.build(scene.mesh, V, dyn.settings.dhat)
        db = b - b_to
        return (dyn._smooth_energy(y, c, z, anchors) + 0.5 * K * np.sum(db * db)
                + float(dyn.barrier(col, scene.mesh, V)))

    def solve(dyn, scene, x, v, h, y, b, b_to, anchors):
        s = dyn.settings
        c = dyn.model.mass * (1.0 / (h * h) + s.damping / h)
        z = (x + h * v + s.damping * h * x) / (1.0 + s.damping * h)
        K = kmul * float(c.max())
        n = dyn.n
        enough = n * dyn.model.weight_mean * s.tolerance
        it = 0
        while it < MAX_ITERATIONS:
            e, g, H = system(dyn, scene, y, b, c, z, anchors, b_to, K)
            d = pcg(H, -g, factor(H).solve, 3)
            slope = float(np.sum(g * d))
            if not slope < 0 or (-0.5 * slope < enough and np.max(np.abs(b - b_to)) < 1e-7):
                break
            dy, dbv = d[: 3 * n].reshape(-1, 3), d[3 * n:].reshape(-1, 3)
            alpha = min(1.0, stacked_free(scene, y, b, y + dy, b + dbv))
            while alpha > 1e-10 and energy(dyn, scene, y + alpha * dy, b + alpha * dbv, c, z,
                                           anchors, b_to, K) > e + 1e-4 * alpha * slope:
                alpha *= 0.5
            if alpha <= 1e-10:
                break
            y, b, it = y + alpha * dy, b + alpha * dbv, it + 1
        stats["kinematic_iterations"] += it
        return y, b, it

    def advance(self, x, v, h, body_from, body_to, anchors_at=None, substep_limit=None):
        scene = self.scene(x, [body_from, body_to])
        u = self.carried(x, body_from, body_to)
        free = scene.free_fraction(x, body_from, x + u, body_to)
        if free >= 1.0:
            return plain(self, x, v, h, body_from, body_to, anchors_at, substep_limit)
        stats["kinematic_frames"] += 1
        idx = scene.body_vertices
        bf, bt = body_from[idx], body_to[idx]
        part = 0.9 * free
        anchors = None if anchors_at is None else anchors_at(body_to)
        y, b, it = solve(self, scene, x, v, h, x + part * u, bf + part * (bt - bf), bt, anchors)
        if np.max(np.abs(b - bt)) < gap and stacked_free(scene, y, b, y, bt) >= 1.0:
            y2, st = self.solve_step(scene, x, v, h, body_to, y, anchors)
            return y2, (y2 - x) / h, {**st, "substeps": 1, "iterations": st["iterations"] + it}
        stats["fallbacks"] += 1
        return plain(self, x, v, h, body_from, body_to, anchors_at, substep_limit)

    D.ClothDynamics.advance = advance


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("target", help="gallery sample id SUBJECT-GARMENT-POSE, e.g. S005-G004-P003")
    ap.add_argument("--kmul", type=float, default=1e8, help="body penalty / largest inertia weight")
    ap.add_argument("--gap", type=float, default=1e-5, help="m, body distance to its target "
                                                            "accepted before the final solve")
    ap.add_argument("--dynamics", default="{}", help="JSON of DynamicsSettings overrides")
    ap.add_argument("--baseline", action="store_true", help="generator 4.0.0 as it is")
    args = ap.parse_args(argv)
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from generator4_gallery import SECRET, SETTINGS

    from dressmeup.data.synth.config import SynthConfig
    from dressmeup.data.synth.dataset4 import Gen4Config, make_plan
    from dressmeup.data.synth.generator4 import SimulationFailed, build, dress, load_body_kit

    stats = {"kinematic_frames": 0, "fallbacks": 0, "kinematic_iterations": 0}
    if not args.baseline:
        install(args.kmul, args.gap, stats)
    sid, gid, pid = args.target.split("-")
    c = SynthConfig(**{**SETTINGS, "secret": SECRET})
    g4 = Gen4Config.from_synth(c)
    dyn = dataclasses.replace(g4.sim.dynamics, **json.loads(args.dynamics))
    g4 = dataclasses.replace(g4, sim=dataclasses.replace(g4.sim, dynamics=dyn))
    plan = make_plan(c, g4)
    g = plan["garments"][gid]
    kit = load_body_kit(g4.body_model)
    design = np.asarray(plan["subjects"][g["design_subject"]]["shape"], np.float64)
    built = build(kit, g["type"], g["params"], design, g4.sim.edge_length)
    print(g["type"], g["fit"], plan["poses"][pid]["family"], len(built.vertices), "vertices",
          flush=True)

    def on_frame(k, x, st):
        if st["substeps"] > 1 or st["iterations"] > 20:
            print(f"frame {k}: {st['substeps']} sub-steps, {st['iterations']} iterations, "
                  f"{st['contacts']} contacts", flush=True)

    t0 = time.process_time()
    try:
        res = dress(kit, built, np.asarray(plan["subjects"][sid]["shape"]),
                    np.asarray(plan["poses"][pid]["pose"]), g4.sim, on_frame=on_frame)
        print({k: res.stats[k] for k in ("substeps", "iterations", "unconverged_frames",
                                         "intersection_free", "inside_area_pct", "cpu_s")})
    except SimulationFailed as exc:
        print(f"failed: {exc} ({time.process_time() - t0:.1f} CPU-s)")
    print(stats)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
