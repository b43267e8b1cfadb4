"""Ground truth by simulation: our quasi-static solver against newton's VBD, same garments.

A garment is made on the slim tall woman (S01) and worn by the heavy short older man (S02),
the largest shape change of the subject table; the body goes from S01 at rest to S02 at rest
(shape path) and then to the pose (pose path), with the same intermediate bodies for both
solvers (:func:`dressmeup.data.synth.quasistatic.path_bodies`), and the cloth follows from its
designed shape. Per garment, pose and solver: share of the garment's area inside the body
(face centroids, winding number), self-intersecting faces (pymeshlab), edge strain
|l/L - 1| (mean, 99th percentile), CPU seconds; for the sensitivity, the median and mean
per-vertex distance between the result and a run from a start perturbed by 5 mm (random
direction per vertex) and a run twice as long (twice the intermediate bodies, half the
tolerances; newton: twice the substeps). The load average is printed beside every timing.

    python benchmarks/perf/physics_gt.py [--solvers ours,newton] [--runs base,perturbed,longer]
        [--cases skirt:sitting,dress:sitting,shorts:sitting,t-shirt:arms-raised]
        [--json OUT.json]

newton (``pip install newton``, 1.8.0; Warp's CPU device): the VBD cloth solver with
self-contact; the body is a kinematic triangle mesh of the same particle system (massless
particles set every substep by interpolating between the intermediate bodies, so VBD's
vertex-triangle and edge-edge contact handles cloth against body as it handles cloth against
cloth), the supported vertices are massless and follow the same body anchors as ours; each
intermediate body takes ``--newton-frame`` seconds of simulated time, then the cloth settles
until its fastest particle moves slower than 1 mm/s (at most 2 s). Only the body within
15 cm of the designed garment is in newton's particle system (its contact detection runs
over every triangle each substep).
"""

from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np

DESIGN, WEARER = 0, 1  # SUBJECTS rows: slim tall woman -> heavy short older man
GARMENT_ROW = {"t-shirt": 0, "skirt": 1, "dress": 2, "shorts": 3, "trousers": 4}
DEFAULT_CASES = ("skirt:sitting,dress:sitting,shorts:sitting,t-shirt:sitting,"
                 "skirt:arms-raised,t-shirt:arms-raised")


def load() -> str:
    """The 1-minute load average, for the timing columns."""
    return f"{os.getloadavg()[0]:.1f}"


class Scene:
    """Body model, the two subjects and the garment builder (one thread)."""

    def __init__(self) -> None:
        from dressmeup.body import BodyParams, get_body_model
        from dressmeup.data.synth.common import SUBJECTS
        from dressmeup.data.synth.garments import BodyFrame

        self.BodyParams = BodyParams
        self.model = get_body_model("anny")
        self.keep, self.skin_F = self.model.skin()
        self.names = tuple(self.model.joint_names)
        W = np.asarray(self.model.skinning_weights)[self.keep]
        self.labels = np.array(self.names)[W.argmax(1)]
        self.frame0 = BodyFrame.from_joints(
            self.model.posed(self.model.default_params()).rest_joints, self.names)
        self.shapes = [np.asarray(SUBJECTS[r][1], np.float64) for r in (DESIGN, WEARER)]
        rest = self.model.posed(BodyParams(model=self.model.name, shape=self.shapes[0],
                                           pose=np.zeros((len(self.names), 3))))
        self.frame = BodyFrame.from_joints(rest.rest_joints, self.names)

    def body(self, shape: np.ndarray, pose: np.ndarray | None = None) -> np.ndarray:
        from dressmeup.data.synth.common import BODY_DECIMALS, quantize

        pose = np.zeros((len(self.names), 3)) if pose is None else pose
        out = self.model.posed(self.BodyParams(model=self.model.name, shape=shape, pose=pose))
        return quantize(np.asarray(out.vertices)[self.keep], BODY_DECIMALS)

    def garment(self, gtype: str):
        from dressmeup.data.synth.common import quantize
        from dressmeup.data.synth.garments import build_garment, sample_params

        params = sample_params(gtype, np.random.default_rng([0, 3, GARMENT_ROW[gtype], 0]))
        g = build_garment(gtype, params, self.body(self.shapes[0]), self.skin_F, self.labels,
                          self.frame, edge_length=0.02)
        return g, quantize(g.vertices, 6)

    def paths(self, gtype: str, pose_name: str, garment_V: np.ndarray, settings):
        """Intermediate bodies: the design body at rest, the shape path, the pose path."""
        from dressmeup.data.synth.poses import pose_axis_angle
        from dressmeup.data.synth.quasistatic import path_bodies

        s0, s1 = self.shapes
        rest = self.body(s0)
        shape = path_bodies(lambda t: self.body((1 - t) * s0 + t * s1), rest, garment_V,
                            settings)
        pose = pose_axis_angle(pose_name, self.names, self.frame0)
        posed = path_bodies(lambda t: self.body(s1, pose * t), shape[-1], garment_V, settings)
        return rest, shape, posed


def perturbed(V: np.ndarray, amount: float = 0.005, seed: int = 1) -> np.ndarray:
    """``V`` with every vertex moved ``amount`` metres in a random direction."""
    u = np.random.default_rng(seed).normal(size=V.shape)
    return V + amount * u / np.linalg.norm(u, axis=1, keepdims=True)


def run_ours(scene: Scene, gtype: str, pose_name: str, run: str) -> dict:
    from dressmeup.data.synth.common import BodyAnchors
    from dressmeup.data.synth.quasistatic import Dresser, DressSettings

    g, V0 = scene.garment(gtype)
    settings = DressSettings().longer(2.0) if run == "longer" else DressSettings()
    rest, shape, posed = scene.paths(gtype, pose_name, V0, settings)
    dresser = Dresser(V0, g.faces, BodyAnchors(V0, g.support, rest, scene.skin_F),
                      scene.skin_F, scene.frame.up, settings)
    t0 = time.process_time()
    x = perturbed(V0) if run == "perturbed" else V0
    x, st0 = dresser.follow(x, [rest])
    x, st1 = dresser.follow(x, shape)
    x, st2 = dresser.follow(x, posed)
    return {"x": x, "faces": g.faces, "rest": V0, "body": posed[-1],
            "cpu_s": time.process_time() - t0,
            "iterations": st0["iterations"] + st1["iterations"] + st2["iterations"],
            "steps": st1["steps"] + st2["steps"], "final": st2,
            "unconverged_steps": st0["unconverged_steps"] + st1["unconverged_steps"]
            + st2["unconverged_steps"]}


def run_newton(scene: Scene, gtype: str, pose_name: str, run: str, frame_s: float) -> dict:
    from dressmeup.data.synth.common import BodyAnchors
    from dressmeup.data.synth.quasistatic import DressSettings

    g, V0 = scene.garment(gtype)
    settings = DressSettings()
    rest, shape, posed = scene.paths(gtype, pose_name, V0, settings)
    anchors = BodyAnchors(V0, g.support, rest, scene.skin_F)
    bodies = [rest, *shape, *posed]
    t0 = time.process_time()
    x = newton_follow(perturbed(V0) if run == "perturbed" else V0, V0, g.faces, anchors,
                      bodies, scene.skin_F, scene.frame.up,
                      frame_s=frame_s, substeps=20 if run == "longer" else 10)
    return {"x": x, "faces": g.faces, "rest": V0, "body": posed[-1],
            "cpu_s": time.process_time() - t0, "steps": len(bodies) - 1}


def newton_follow(start, rest_V, faces, anchors, bodies, body_F, up, frame_s=0.1,
                  substeps=10, settle_s=2.0, speed_tol=1e-3):
    """The garment through ``bodies`` with newton's VBD (see the module docstring)."""
    import newton  # reason: optional dependency of this study only
    import warp as wp  # reason: optional dependency of this study only

    wp.config.quiet = True
    # the body near the garment only (within 15 cm of it as designed): VBD's contact
    # detection runs over every triangle of the particle system each substep
    from scipy.spatial import cKDTree

    held = np.flatnonzero(anchors.weight > 0.5)
    held_at = [anchors.points(B)[held] for B in bodies]  # on the whole bodies
    near = cKDTree(rest_V).query(bodies[0], distance_upper_bound=0.15)[0] < np.inf
    body_F = np.asarray(body_F)[near[np.asarray(body_F)].all(1)]
    keep = np.unique(body_F)
    body_F = np.searchsorted(keep, body_F)
    bodies = [B[keep] for B in bodies]
    n_body = len(keep)
    builder = newton.ModelBuilder(gravity=tuple(float(v) for v in -9.81 * up))
    builder.add_cloth_mesh(pos=wp.vec3(0, 0, 0), rot=wp.quat_identity(), scale=1.0,
                           vel=wp.vec3(0, 0, 0), vertices=[wp.vec3(*v) for v in bodies[0]],
                           indices=np.asarray(body_F).ravel().tolist(), density=0.0,
                           tri_ke=0.0, tri_ka=0.0, tri_kd=0.0, edge_ke=0.0, edge_kd=0.0)
    builder.add_cloth_mesh(pos=wp.vec3(0, 0, 0), rot=wp.quat_identity(), scale=1.0,
                           vel=wp.vec3(0, 0, 0), vertices=[wp.vec3(*v) for v in rest_V],
                           indices=np.asarray(faces).ravel().tolist(), density=0.15,
                           tri_ke=77.0, tri_ka=66.0, tri_kd=1e-2, edge_ke=5e-4, edge_kd=1e-3)
    builder.color(include_bending=True)
    model = builder.finalize(device="cpu")
    model.soft_contact_ke, model.soft_contact_kd, model.soft_contact_mu = 1e4, 1e-2, 0.0
    flags = model.particle_flags.numpy()
    kin = np.concatenate([np.arange(n_body), n_body + held])
    flags[kin] &= ~int(newton.ParticleFlags.ACTIVE)
    model.particle_flags = wp.array(flags, dtype=model.particle_flags.dtype, device="cpu")
    solver = newton.solvers.SolverVBD(model, iterations=10, particle_enable_self_contact=True,
                                      particle_self_contact_margin=0.005,
                                      particle_self_contact_gap=0.003)
    s0, s1, ctl = model.state(), model.state(), model.control()
    q = s0.particle_q.numpy()
    q[n_body:] = start
    s0.particle_q.assign(q)
    dt = frame_s / substeps

    def place(state, body_V, held_V):
        p = state.particle_q.numpy()
        p[:n_body] = body_V
        p[n_body + held] = held_V
        state.particle_q.assign(p)

    prev, prev_h = bodies[0], held_at[0]
    for body_V, held_V in zip([bodies[0], *bodies], [held_at[0], *held_at], strict=True):
        for k in range(1, substeps + 1):
            B = prev + (body_V - prev) * (k / substeps)
            Hk = prev_h + (held_V - prev_h) * (k / substeps)
            place(s0, B, Hk)
            place(s1, B, Hk)
            s0.clear_forces()
            solver.step(s0, s1, ctl, None, dt)
            s0, s1 = s1, s0
        prev, prev_h = body_V, held_V
    t = 0.0
    while t < settle_s:
        for _ in range(substeps):
            place(s0, prev, prev_h)
            place(s1, prev, prev_h)
            solver.step(s0, s1, ctl, None, dt)
            s0, s1 = s1, s0
        t += frame_s
        if np.abs(s0.particle_qd.numpy()[n_body:]).max() < speed_tol:
            break
    return s0.particle_q.numpy()[n_body:].astype(np.float64)


def figures(res: dict) -> dict:
    from dressmeup.data.synth.common import drape_stats

    return drape_stats(res["x"], res["faces"], res["rest"], res["body"],
                       Scene_cache["scene"].skin_F)


Scene_cache: dict = {}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--solvers", default="ours,newton")
    ap.add_argument("--runs", default="base,perturbed,longer")
    ap.add_argument("--cases", default=DEFAULT_CASES)
    ap.add_argument("--newton-frame", type=float, default=0.1)
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
    from dressmeup.data.synth.jobs import single_threaded

    rows = []
    with single_threaded():
        scene = Scene_cache["scene"] = Scene()
        print(f"# garments made on S01, worn by S02; load at start {load()}")
        print("| solver | garment | pose | run | inside area % | self-int. faces | strain mean "
              "| strain p99 | moved median mm | moved mean mm | iterations | steps | CPU s "
              "| load |")
        print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
        for case in args.cases.split(","):
            gtype, pose_name = case.split(":")
            for solver in args.solvers.split(","):
                base = None
                for run in args.runs.split(","):
                    if solver == "ours":
                        res = run_ours(scene, gtype, pose_name, run)
                    else:
                        res = run_newton(scene, gtype, pose_name, run, args.newton_frame)
                    st = figures(res)
                    moved = (np.linalg.norm(res["x"] - base["x"], axis=1) * 1000
                             if base is not None else np.zeros(1))
                    if run == "base":
                        base = res
                    row = {"solver": solver, "garment": gtype, "pose": pose_name, "run": run,
                           **st, "moved_median_mm": float(np.median(moved)),
                           "moved_mean_mm": float(moved.mean()),
                           "moved_p95_mm": float(np.quantile(moved, 0.95)),
                           "cpu_s": res["cpu_s"], "load": float(load()),
                           "iterations": res.get("iterations"), "steps": res["steps"],
                           "final": res.get("final"),
                           "unconverged_steps": res.get("unconverged_steps")}
                    rows.append(row)
                    print(f"| {solver} | {gtype} | {pose_name} | {run} | "
                          f"{st['inside_area_pct']:.2f} | {st['self_intersecting_faces']} | "
                          f"{st['strain_mean']:.3f} | {st['strain_p99']:.3f} | "
                          f"{row['moved_median_mm']:.2f} | {row['moved_mean_mm']:.2f} | "
                          f"{row['iterations']} | {row['steps']} | {res['cpu_s']:.1f} | "
                          f"{load()} |", flush=True)
                    if args.json:
                        with open(args.json, "w") as fh:
                            json.dump(rows, fh, indent=1, default=str)


if __name__ == "__main__":
    main()
