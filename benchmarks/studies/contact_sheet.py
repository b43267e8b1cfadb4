"""Draw docs/images/synthetic-contact-sheet.png: one row per garment type of the
``synth-retarget-v2`` data (3 subjects x 4 garments x 5 poses, anny body, seed 0), one
column per pose, the posed body in grey and the draped, textured garment.

Usage::

    python benchmarks/studies/contact_sheet.py --data /tmp/synth-retarget-v2 \\
        [--out docs/images/synthetic-contact-sheet.png]

The data are generated first when ``--data`` does not hold them yet (resumable; about 20
minutes on 2 cores), with exactly the edition's pinned generator parameters.
"""

from __future__ import annotations

import argparse
from pathlib import Path

EDITION = "synth-retarget-v2"


def main(argv: list[str] | None = None) -> int:
    from dressmeup.runs import build_data
    from dressmeup.viz.contact_sheet import render_dataset_contact_sheet

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, required=True, help=f"data folder of {EDITION} (made when missing)")
    ap.add_argument("--out", type=Path, default=Path("docs/images/synthetic-contact-sheet.png"))
    ap.add_argument("--max-garments", type=int, default=7, help="rows (7: one per garment type)")
    ap.add_argument("--max-poses", type=int, default=5)
    args = ap.parse_args(argv)
    root = build_data(EDITION, args.data, log=print)
    render_dataset_contact_sheet(root, args.out, max_garments=args.max_garments, max_poses=args.max_poses)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
