"""Record synchronised Azure Kinects (one MKV per camera) and board shots for calibration.

UNTESTED ON HARDWARE: written against pyk4a's documented API (PyK4A, Config, PyK4ARecord,
WiredSyncMode); the Azure Kinect SDK could not be installed where dressmeup is developed.
Needs the Azure Kinect SDK and ``pip install dressmeup[kinect]``.

Synchronisation: daisy-chain the sync cables; the master (``--master`` index, default 0)
starts last, subordinates start first, each subordinate's depth capture is delayed by
``160 us * its rank`` so the depth lasers do not interfere (Microsoft's recommendation).

Examples::

    # list devices and dump factory intrinsics into a template rig.json
    python capture/record_kinect.py intrinsics --out template.json
    # board shots for calibration: IR images IMAGES/shot<k>/<serial>.png (press Enter per shot)
    python capture/record_kinect.py shots --out calib/ --shots 12
    # record 2 seconds of the subject
    python capture/record_kinect.py record --out takes/S01-P1/ --seconds 2
    # then: dressmeup session from MKVs (see capture/README.md)
"""

from __future__ import annotations

import argparse
import sys
import threading
import time
from pathlib import Path

SUBORDINATE_DELAY_US = 160


def _config(pyk4a, mode: str, delay_us: int):
    sync = {"master": pyk4a.WiredSyncMode.MASTER, "subordinate": pyk4a.WiredSyncMode.SUBORDINATE,
            "standalone": pyk4a.WiredSyncMode.STANDALONE}[mode]
    return pyk4a.Config(color_resolution=pyk4a.ColorResolution.RES_720P,
                        color_format=pyk4a.ImageFormat.COLOR_BGRA32,
                        depth_mode=pyk4a.DepthMode.NFOV_UNBINNED, camera_fps=pyk4a.FPS.FPS_30,
                        synchronized_images_only=True, wired_sync_mode=sync,
                        subordinate_delay_off_master_usec=delay_us)


def _devices(pyk4a, master: int):
    n = pyk4a.connected_device_count()
    if n == 0:
        raise SystemExit("no Azure Kinect connected")
    devs = []
    rank = 0
    for i in range(n):
        mode = "standalone" if n == 1 else ("master" if i == master else "subordinate")
        delay = 0 if mode != "subordinate" else SUBORDINATE_DELAY_US * (rank := rank + 1)
        dev = pyk4a.PyK4A(config=_config(pyk4a, mode, delay), device_id=i)
        devs.append((i, mode, dev))
    # subordinates first, master last
    devs.sort(key=lambda d: d[1] == "master")
    for _, _, dev in devs:
        dev.start()
    return devs


def cmd_intrinsics(args) -> int:
    import pyk4a

    from dressmeup.capture.camera import Camera
    from dressmeup.capture.rig import Rig, save_rig

    cams = []
    for i, _mode, dev in _devices(pyk4a, args.master):
        K = dev.calibration.get_camera_matrix(pyk4a.CalibrationType.DEPTH)
        D = list(dev.calibration.get_distortion_coefficients(pyk4a.CalibrationType.DEPTH))[:8]
        cap = dev.get_capture()
        h, w = cap.depth.shape
        cams.append(Camera(serial=dev.serial, width=w, height=h, fx=K[0][0], fy=K[1][1], cx=K[0][2], cy=K[1][2],
                           distortion=(D + [0.0] * 8)[:8]))
        dev.stop()
        print(f"device {i}: serial {dev.serial}, {w}x{h}")
    save_rig(Rig(cameras=cams, name="kinect-template"), args.out)
    print(f"wrote {args.out} (extrinsics are identity: run capture/calibrate.py)")
    return 0


def cmd_shots(args) -> int:
    import cv2
    import numpy as np
    import pyk4a

    devs = _devices(pyk4a, args.master)
    try:
        for k in range(args.shots):
            input(f"shot {k + 1}/{args.shots}: place the board, then press Enter")
            shot = Path(args.out) / f"shot{k:02d}"
            shot.mkdir(parents=True, exist_ok=True)
            for _, _, dev in devs:
                ir = dev.get_capture().ir.astype(np.float32)
                img = np.clip(255 * ir / max(np.percentile(ir, 99), 1), 0, 255).astype(np.uint8)
                cv2.imwrite(str(shot / f"{dev.serial}.png"), img)
    finally:
        for _, _, dev in devs:
            dev.stop()
    return 0


def cmd_record(args) -> int:
    import pyk4a

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    devs = _devices(pyk4a, args.master)
    stop = time.monotonic() + args.seconds
    errors: list[str] = []

    def run(dev) -> None:
        try:
            rec = pyk4a.PyK4ARecord(path=str(out / f"{dev.serial}.mkv"), config=dev._config, device=dev)
            rec.create()
            while time.monotonic() < stop:
                rec.write_capture(dev.get_capture())
            rec.flush()
            rec.close()
        except Exception as exc:  # report per device, keep the others
            errors.append(f"{dev.serial}: {exc}")

    threads = [threading.Thread(target=run, args=(dev,)) for _, _, dev in devs]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for _, _, dev in devs:
        dev.stop()
    for e in errors:
        print(f"recording failed on {e}", file=sys.stderr)
    print(f"wrote {len(devs) - len(errors)} recording(s) to {out}")
    return 1 if errors else 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--master", type=int, default=0, help="device index of the sync master")
    sub = ap.add_subparsers(dest="cmd", required=True)
    p = sub.add_parser("intrinsics")
    p.add_argument("--out", required=True)
    p.set_defaults(func=cmd_intrinsics)
    p = sub.add_parser("shots")
    p.add_argument("--out", required=True)
    p.add_argument("--shots", type=int, default=12)
    p.set_defaults(func=cmd_shots)
    p = sub.add_parser("record")
    p.add_argument("--out", required=True)
    p.add_argument("--seconds", type=float, default=2.0)
    p.set_defaults(func=cmd_record)
    args = ap.parse_args(argv)
    try:
        import pyk4a  # noqa: F401
    except ImportError:
        print("record_kinect needs pyk4a and the Azure Kinect SDK: pip install dressmeup[kinect]", file=sys.stderr)
        return 2
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
