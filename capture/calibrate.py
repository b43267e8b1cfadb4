"""Estimate a rig's extrinsics from ChArUco-board images and write rig.json.

Thin wrapper over :mod:`dressmeup.capture.calibration`.

Input: a template rig.json with every camera's intrinsics (the Azure Kinect factory
calibration, see record_kinect.py --dump-intrinsics) and images ``IMAGES/<shot>/<serial>.png``:
for each placement of the board ("shot"), one image per camera, taken at the same time.
Every camera must share at least one shot with a camera already linked to the reference.

Example::

    python capture/calibrate.py --rig template.json --images calib/ --out session/rig.json \
        --squares 7x5 --square 0.12 --marker 0.09 --dictionary DICT_5X5_100
"""

from __future__ import annotations

import argparse
import sys


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rig", required=True, help="template rig.json (intrinsics; reference camera pose)")
    ap.add_argument("--images", required=True, help="folder of shot folders with <serial>.png images")
    ap.add_argument("--out", required=True, help="rig.json to write")
    ap.add_argument("--squares", default="7x5", help="board squares, XxY (default 7x5)")
    ap.add_argument("--square", type=float, default=0.12, help="square side in metres")
    ap.add_argument("--marker", type=float, default=0.09, help="marker side in metres")
    ap.add_argument("--dictionary", default="DICT_5X5_100", help="OpenCV aruco dictionary name")
    args = ap.parse_args(argv)

    from dressmeup.capture.calibration import BoardSpec, calibrate_rig
    from dressmeup.capture.rig import load_rig, save_rig
    from dressmeup.errors import DressmeupError

    try:
        sx, sy = (int(v) for v in args.squares.lower().split("x"))
    except ValueError:
        print(f"--squares: expected XxY such as 7x5, got {args.squares!r}", file=sys.stderr)
        return 2
    spec = BoardSpec(sx, sy, args.square, args.marker, args.dictionary)
    try:
        rig, seen = calibrate_rig(args.images, load_rig(args.rig), spec)
    except (DressmeupError, FileNotFoundError) as exc:
        print(f"calibrate: error: {exc}", file=sys.stderr)
        return 2
    for shot, serials in sorted(seen.items()):
        print(f"{shot}: board seen by {', '.join(serials)}")
    save_rig(rig, args.out)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
