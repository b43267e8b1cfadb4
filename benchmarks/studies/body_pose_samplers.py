"""Measure the body and pose samplers on anny and draw docs/images/sampled-bodies-poses.png:
24 sampled bodies (seed 0), each in a pose of one family (families in turn), and per
family the acceptance rate of the self-intersection check and the time to draw 24 poses
(one per body).

Usage::

    python benchmarks/studies/body_pose_samplers.py [--out docs/images/sampled-bodies-poses.png]
"""

from __future__ import annotations

import argparse
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    import numpy as np

    from dressmeup.body import get_body_model
    from dressmeup.body.params import BodyParams
    from dressmeup.data.synth.sampling import POSE_FAMILIES, sample_bodies, sample_family_on_bodies
    from dressmeup.viz.contact_sheet import MeshLayer, render_contact_sheet

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("docs/images/sampled-bodies-poses.png"))
    ap.add_argument("--n", type=int, default=24)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)

    model = get_body_model("anny")
    keep, F = model.skin()
    rng = np.random.default_rng(args.seed)
    bodies = sample_bodies(rng, args.n)
    draws = {}
    print("| family | accepted / drawn | acceptance | seconds for", args.n, "poses |")
    print("|---|---|---|---|")
    for fam in POSE_FAMILIES:
        d = draws[fam] = sample_family_on_bodies(model, bodies, fam, rng)
        print(f"| {fam} | {len(d.poses)} / {d.draws} | {d.acceptance:.0%} | {d.seconds:.1f} |",
              flush=True)
    cells, titles = [], []
    for k, body in enumerate(bodies):
        fam = POSE_FAMILIES[k % len(POSE_FAMILIES)]
        out = model.posed(BodyParams(model=model.name, shape=body.shape, pose=draws[fam].poses[k]))
        V = out.vertices[keep]
        color = (0.85, 0.62, 0.55) if body.female else (0.55, 0.68, 0.85)
        cells.append([MeshLayer(V, F, color)])
        titles.append(f"{body.name}\n{fam}")
    right, up = np.array([0.5, 0.0, 0.866]), np.array([0.0, 1.0, 0.0])  # three-quarter view
    render_contact_sheet(cells, args.out, right, up, ncols=8, titles=titles, cell_size=1.7,
                         cell_height=2.4, dpi=110)
    print("wrote", args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
