"""Draw a registration run's fits on synth-registration-v3: one cell a scan, rows the poses,
columns the subjects.

    python benchmarks/studies/registration_fits_sheet.py --submission SUB --result RES \
        --data DATA --out docs/images/registration/edition-fits.png

SUB is the submission folder of the run (``<sample_id>.npz`` body parameters), RES the
folder ``dressmeup score`` wrote for it (``per_sample.parquet``: the captions' V2V), DATA
the edition's data. Each cell shows the fitted body (grey; red where more than 15 mm
outside the scan, as ``dressmeup register`` draws it) over the scan's surface samples
(blue), seen from the front and the left side of the **true** body, so a fit facing
backwards, with its arms down in a T-pose or standing in a sitting scan is plain to see.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np


def _cell(sample, pred_path: Path, n_points: int = 6000) -> dict:
    """What one cell draws: the fitted body (vertices (n, 3) m, faces), its per-vertex
    distance outside the scan (mm), the scan samples (p, 3) m, and the true body's
    facing (3,)."""
    from scipy.spatial.transform import Rotation

    from dressmeup.body import BodyParams, get_body_model
    from dressmeup.body.registration.metrics import outside_distances_mm
    from dressmeup.geometry.sampling import sample_surface

    pred = BodyParams.load(pred_path)
    model = get_body_model(pred.model)
    V = np.asarray(model.posed(pred).vertices, np.float64)
    F = np.asarray(model.faces, np.int64)
    SV, SF = sample.scan()[:2]
    P = sample_surface(np.asarray(SV, np.float64), np.asarray(SF, np.int64), n_points, seed=0)[0]
    truth = sample.body()
    forward = Rotation.from_rotvec(np.asarray(truth.pose)[0]).apply([0.0, 0.0, 1.0])
    return {"V": V, "F": F, "outside": outside_distances_mm(V, F, P), "P": P,
            "forward": forward}


def draw(submission: str, result: str, data: str, out: str) -> Path:
    """Write the sheet; returns its path."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from dressmeup.bench.scoring.results import load_result
    from dressmeup.data import Dataset
    from dressmeup.viz.figure import save_png
    from dressmeup.viz.registration import draw_registration_views

    ds = Dataset(data)
    man = ds.manifest.set_index("sample_id")
    table = load_result(result).table.set_index("sample_id")
    poses = sorted(man["pose_id"].unique())
    subjects = sorted(man["subject_id"].unique())
    fig, axes = plt.subplots(len(poses), 2 * len(subjects),
                             figsize=(1.6 * 2 * len(subjects), 2.4 * len(poses)), squeeze=False)
    for sid in table.index:
        r, c = poses.index(man.loc[sid, "pose_id"]), subjects.index(man.loc[sid, "subject_id"])
        cell = _cell(ds[sid], Path(submission) / f"{sid}.npz")
        draw_registration_views(axes[r, 2 * c:2 * c + 2], cell["V"], cell["F"], cell["P"],
                                forward=cell["forward"], outside_mm=cell["outside"])
        axes[r, 2 * c].set_title(
            f"{sid} {ds.info['poses'][man.loc[sid, 'pose_id']]}, "
            f"{man.loc[sid, 'garment_type']}: V2V {1000 * table.loc[sid, 'v2v']:.1f} mm",
            fontsize=6.5, loc="left")
    fig.suptitle("fitted body (grey; red: > 15 mm outside the scan) over the scan (blue), "
                 "front and left side of the true body", fontsize=8)
    fig.tight_layout()
    return save_png(fig, out, dpi=90)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--submission", required=True, help="the run's submission folder")
    ap.add_argument("--result", required=True, help="its scored result folder")
    ap.add_argument("--data", required=True, help="the edition's data folder")
    ap.add_argument("--out", required=True, help="PNG to write")
    args = ap.parse_args(argv)
    sys.stdout.write(f"wrote {draw(args.submission, args.result, args.data, args.out)}\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
