"""Generator 4 on the cross-check's 15 mm timing garment (mini-v5 S002-G001-P002's t-shirt
rebuilt at 15 mm edges, the same walking motion): CPU seconds and figures."""
import dataclasses
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, "/work/main/benchmarks/perf")

def main():
    import synth_g4_figures as f

    from dressmeup.data.synth.generator4 import SimulationFailed, build, dress
    from dressmeup.data.synth.jobs import single_threaded
    root = Path("/tmp/m5")
    info, samples, _ = f.read_samples(root)
    item = next(s for s in samples if s["id"] == "S002-G001-P002")
    with single_threaded():
        settings, kit, built, body, _ = f.replay_inputs(root, item)
        g = item["garment"]
        design = np.asarray(info["subjects"][g["design_subject"]]["shape"], np.float64)
        fine = build(kit, g["type"], g["params"], design, 0.015)
        st = dataclasses.replace(settings, edge_length=0.015)
        print("vertices", len(fine.vertices), "frames", st.motion.frames, "load", os.getloadavg(), flush=True)
        t0 = time.process_time()
        def frame(k, x, s):
            if k % 5 == 0:
                print(f"frame {k} substeps {s['substeps']} iters {s['iterations']} cpu {time.process_time()-t0:.0f}", flush=True)
        try:
            res = dress(kit, fine, body["shape"], body["pose"], st, on_frame=frame)
            out = {k: res.stats[k] for k in ("cpu_s", "substeps", "iterations", "unconverged_frames", "intersection_free", "inside_area_pct", "self_intersecting_faces")}
        except SimulationFailed as exc:
            out = {"failed": str(exc), "cpu_s": time.process_time() - t0}
        out["vertices"] = len(fine.vertices)
        out["load"] = os.getloadavg()
        print(json.dumps(out, indent=1))

if __name__ == "__main__":
    main()
