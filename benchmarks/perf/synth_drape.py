"""Cloth solver settings of the synthetic generator, compared on the same garments.

For a few garments made on one body and fitted to another (the v3 shape change), draped in
hard poses (sitting, arms raised), each variant reports the simulator-comparison criteria
per sample: deepest vertex inside the body (mm), share of garment area inside the
body (%), mean and 99th-percentile edge strain, self-intersecting faces (pymeshlab) and the
CPU seconds per sample, with the load average beside every timing.

    python benchmarks/perf/synth_drape.py [--body-model anny] [--variants v2,v3]

Variants: ``v2`` = generator 1.1.0's solver (direct drape, no self-collision, 1 mm final
clearance); ``v3`` = generator 2.1.0 (3-step pose path, self-collision 10 mm, 3 mm clearance);
``v3-noself`` and ``v3-direct`` switch one of the two off.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import time

import numpy as np

GARMENTS = (("t-shirt", 0), ("skirt", 1), ("dress", 2))
DESIGN, WEARER = 0, 1  # SUBJECTS rows: slim tall woman -> heavy short man
POSES = ("sitting", "arms-raised")


def variants():
    from dressmeup.data.synth.drape import DrapeSettings
    from dressmeup.data.synth.generator2 import drape_settings_2x

    v3 = drape_settings_2x()
    return {
        "v2": (DrapeSettings(), 1),
        "v3": (v3, 3),
        "v3-noself": (dataclasses.replace(v3, self_stiffness=0.0), 3),
        "v3-direct": (v3, 1),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--body-model", default="anny")
    ap.add_argument("--variants", default="v2,v3,v3-noself,v3-direct")
    ap.add_argument("--edge-length", type=float, default=None)
    ap.add_argument("--garments", default="t-shirt,skirt,dress")
    args = ap.parse_args()

    from dressmeup.body import BodyParams, get_body_model
    from dressmeup.data.synth.common import (
        BODY_DECIMALS,
        DEFAULT_EDGE_LENGTH,
        SUBJECTS,
        drape_stats,
        quantize,
    )
    from dressmeup.data.synth.drape import drape
    from dressmeup.data.synth.dressing import garment_weights
    from dressmeup.data.synth.garments import BodyFrame, build_garment, sample_params
    from dressmeup.data.synth.generator2 import FittedGarment, PoseDraper, transfer_to_body
    from dressmeup.data.synth.jobs import single_threaded
    from dressmeup.data.synth.poses import pose_axis_angle

    chosen = {k: v for k, v in variants().items() if k in args.variants.split(",")}
    edge = args.edge_length or DEFAULT_EDGE_LENGTH.get(args.body_model, 0.02)
    with single_threaded():
        model = get_body_model(args.body_model)
        keep, skin_F = model.skin()
        names = tuple(model.joint_names)
        body_W = np.asarray(model.skinning_weights)[keep]
        labels = np.array(names)[body_W.argmax(1)]
        frame0 = BodyFrame.from_joints(model.posed(model.default_params()).rest_joints, names)
        bodies = []
        for row in (DESIGN, WEARER):
            shape = np.asarray(SUBJECTS[row][1])
            rest = model.posed(BodyParams(model=model.name, shape=shape,
                                          pose=np.zeros((len(names), 3))))
            bodies.append((shape, quantize(rest.rest_vertices[keep], BODY_DECIMALS),
                           BodyFrame.from_joints(rest.rest_joints, names)))
        print(f"# {args.body_model}: garments made on {SUBJECTS[DESIGN][0]}, worn by "
              f"{SUBJECTS[WEARER][0]}; load at start {os.getloadavg()[0]:.1f}")
        print("| variant | garment | pose | deepest mm | inside area % | strain mean | "
              "strain p99 | self-int. faces | CPU s | load |")
        print("|---|---|---|---|---|---|---|---|---|---|")
        totals: dict[str, list] = {k: [] for k in chosen}
        for gtype, k in [x for x in GARMENTS if x[0] in args.garments.split(",")]:
            params = sample_params(gtype, np.random.default_rng([0, 3, k, 0]))
            (s0, V_d, fr_d), (s1, V_w, fr_w) = bodies
            g = build_garment(gtype, params, V_d, skin_F, labels, fr_d, edge_length=edge)
            V0 = quantize(g.vertices, 6)
            for name, (settings, steps) in chosen.items():
                t0 = time.process_time()
                start = transfer_to_body(V0, V_d, V_w, skin_F)
                fitted = drape(V0, g.faces, start, g.support, V_w, skin_F, fr_w.up,
                               settings, exact_faces=True).vertices  # as the generator
                W = garment_weights(FittedGarment(fitted, g.faces, gtype), V_w, skin_F, body_W,
                                     names, fr_w)
                draper = PoseDraper(model, keep, skin_F, V0, g.faces, g.support, fitted, W,
                                    s1, settings, steps)
                fit_s = (time.process_time() - t0) / len(POSES)
                for pose_name in POSES:
                    t1 = time.process_time()
                    res, body_V = draper(pose_axis_angle(pose_name, names, frame0), fr_w.up)
                    sec = time.process_time() - t1 + fit_s
                    st = drape_stats(res.vertices, g.faces, V0, body_V, skin_F)
                    totals[name].append([st["deepest_mm"], st["inside_area_pct"],
                                         st["strain_mean"], st["strain_p99"],
                                         st["self_intersecting_faces"], sec])
                    print(f"| {name} | {gtype} | {pose_name} | {st['deepest_mm']:.1f} | "
                          f"{st['inside_area_pct']:.2f} | {st['strain_mean']:.3f} | "
                          f"{st['strain_p99']:.3f} | {st['self_intersecting_faces']} | "
                          f"{sec:.1f} | {os.getloadavg()[0]:.1f} |", flush=True)
        print("\n| variant | deepest mm (max) | inside area % (mean) | strain mean | "
              "strain p99 (mean) | self-int. faces (mean) | CPU s / sample (mean) |")
        print("|---|---|---|---|---|---|---|")
        for name, rows in totals.items():
            a = np.asarray(rows, float)
            print(f"| {name} | {a[:, 0].max():.1f} | {a[:, 1].mean():.2f} | "
                  f"{a[:, 2].mean():.3f} | {a[:, 3].mean():.3f} | {a[:, 4].mean():.0f} | "
                  f"{a[:, 5].mean():.1f} |")


if __name__ == "__main__":
    main()
