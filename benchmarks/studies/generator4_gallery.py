"""Generate the gallery of generator 4's ground truth: every garment type, the pose families,
at the mini edition's resolution, so that docs/synthetic-data.md can show them.

Three test garments of each category (topwear: t-shirt, long-sleeve, tank-top; bottomwear:
skirt, trousers, shorts; dress: three dresses; fits in turn) on 10 sampled bodies, one pose
of each of the 8 families; per garment its source and one re-pose target (18 samples). The
test split is seeded by a fixed, published secret (this is not an edition). Then run the
figures script on it for the table and the picture::

    python benchmarks/studies/generator4_gallery.py --out /tmp/g4-gallery --workers 2
    python benchmarks/perf/synth_g4_figures.py --data /tmp/g4-gallery --out DIR
"""

from __future__ import annotations

import argparse
import hashlib
import time
from pathlib import Path

SETTINGS = {
    "version": "4.0.0", "body_model": "anny", "edge_length": 0.035, "write_scan": False,
    "texture_size": 64,
    "plan": {"bodies": [0, 0, 10], "poses_per_family": [0, 0, 1], "garments": [0, 0, 3],
             "targets": {"re-pose": [0, 0, 1], "re-shape": [0, 0, 0], "cross": [0, 0, 0]}},
    "motion": {"rest_frames": 10, "shape_frames": 20, "pose_frames": 30, "settle_frames": 15},
}
#: the gallery's published secret
SECRET = hashlib.sha256(b"dressmeup generator-4 gallery").digest()


def main(argv: list[str] | None = None) -> int:
    from dressmeup.data.synth import generate_dataset

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    root = generate_dataset(args.out, secret=SECRET, workers=args.workers, **SETTINGS)
    print(f"{root}: {time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
