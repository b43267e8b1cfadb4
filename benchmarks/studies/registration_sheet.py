"""Draw docs/images/synthetic-registration-v3.png: the 24 scans of ``synth-registration-v3``
(rows: subjects S01-S04, columns: the six poses), front view, the garment's faces red and
the scanned skin grey (the skin under the garment is not in the scan).

Usage::

    python benchmarks/studies/registration_sheet.py --data /tmp/synth-registration-v3 \\
        [--out docs/images/synthetic-registration-v3.png]

The data are generated first when ``--data`` does not hold them yet (about 4 minutes on one
core), with exactly the edition's pinned generator parameters. A scan's garment faces are
its last ``garment_faces`` ones (``dressmeup.data.synth.scans.clothed_scan``).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

EDITION = "synth-registration-v3"
GARMENT_RGB = (0.85, 0.33, 0.28)
SKIN_RGB = (0.72, 0.72, 0.72)


def main(argv: list[str] | None = None) -> int:
    from dressmeup.data import Dataset
    from dressmeup.runs import build_data
    from dressmeup.viz.contact_sheet import MeshLayer, render_contact_sheet

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, required=True,
                    help=f"data folder of {EDITION} (made when missing)")
    ap.add_argument("--out", type=Path, default=Path("docs/images/synthetic-registration-v3.png"))
    args = ap.parse_args(argv)
    ds = Dataset(build_data(EDITION, args.data, log=print))
    m, poses = ds.manifest, ds.info["poses"]
    cells, titles = [], []
    for subject in sorted(m["subject_id"].unique()):
        for pid in sorted(poses):
            row = m[(m["subject_id"] == subject) & (m["pose_id"] == pid)].iloc[0]
            V, F = (np.asarray(a) for a in ds[row["sample_id"]].scan()[:2])
            colors = np.tile(SKIN_RGB, (len(F), 1))
            colors[len(F) - int(row["garment_faces"]):] = GARMENT_RGB
            cells.append([MeshLayer(V, F, face_colors=colors)])
            titles.append(f"{row['sample_id']}\n{row['garment_type']} {poses[pid]}")
    render_contact_sheet(cells, args.out, right=np.array([1.0, 0.0, 0.0]),
                         up=np.array([0.0, 1.0, 0.0]), ncols=len(poses), titles=titles,
                         dpi=90)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
