"""How good is a fit, without a ground-truth body: distances between the fitted body and
the scan, the share of the body poking out of the scan, per body part.

All distances in millimetres. Signed residuals follow the data term: a body vertex whose
nearest scan point lies behind it along its outward normal is *outside* the scan (for a
clothed scan the body should be inside, so an outside body part is a failed fit). Body
vertices in scan holes (no scan point within ``seen_radius``) are left out of the
body -> scan figures.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from dressmeup.geometry.mesh import vertex_normals
from dressmeup.geometry.sampling import sample_surface

#: Body parts as groups of SMPL-like joints (a vertex belongs to the part holding most of
#: its skinning weight).
BODY_PARTS: dict[str, tuple[str, ...]] = {
    "head": ("neck", "head"),
    "torso": ("pelvis", "spine1", "spine2", "spine3", "left_collar", "right_collar"),
    "left_upper_arm": ("left_shoulder",), "right_upper_arm": ("right_shoulder",),
    "left_forearm": ("left_elbow",), "right_forearm": ("right_elbow",),
    "left_hand": ("left_wrist",), "right_hand": ("right_wrist",),
    "left_thigh": ("left_hip",), "right_thigh": ("right_hip",),
    "left_shin": ("left_knee",), "right_shin": ("right_knee",),
    "left_foot": ("left_ankle", "left_foot"), "right_foot": ("right_ankle", "right_foot"),
}


def vertex_parts(model) -> np.ndarray:
    """(n,) int64 index into ``list(BODY_PARTS)`` of each vertex of ``model`` (-1: none)."""
    names = list(model.joint_names)
    W = np.asarray(model.skinning_weights)
    part_w = np.zeros((W.shape[0], len(BODY_PARTS)))
    for k, joints in enumerate(BODY_PARTS.values()):
        ids = [names.index(j) for j in joints if j in names]
        if ids:
            part_w[:, k] = W[:, ids].sum(1)
    out = part_w.argmax(1)
    out[part_w.max(1) <= 0] = -1
    return out


def outside_distances_mm(body_vertices: np.ndarray, body_faces: np.ndarray,
                         scan_points: np.ndarray, seen_radius: float = 0.05) -> np.ndarray:
    """(n,) how far (mm) each body vertex lies outside the scan along its normal (0 inside
    or in a hole: no scan point within ``seen_radius`` m)."""
    V = np.asarray(body_vertices, dtype=np.float64)
    P = np.asarray(scan_points, dtype=np.float64)
    d, nn = cKDTree(P).query(V, k=1, workers=1)
    signed = ((V - P[nn]) * vertex_normals(V, np.asarray(body_faces, np.int64))).sum(1)
    return np.where(d <= seen_radius, np.clip(signed, 0, None) * 1000.0, 0.0)


def fit_metrics(body_vertices: np.ndarray, body_faces: np.ndarray, scan_points: np.ndarray,
                parts: np.ndarray | None = None, outside_mm: float = 15.0,
                seen_radius: float = 0.05, n_samples: int = 60000, seed: int = 0) -> dict:
    """Distances between a fitted body and its scan (no ground truth needed).

    Parameters
    ----------
    body_vertices : (n, 3) float64 fitted body vertices (m); body_faces : (m, 3) int64.
    scan_points : (p, 3) float64 scan points (m) (a mesh's vertices or samples).
    parts : optional (n,) part index per vertex (:func:`vertex_parts`).
    outside_mm : a vertex more than this outside the scan counts as *outside*.
    seen_radius : body vertices with no scan point within this (m) are in a hole: skipped.
    n_samples, seed : body surface samples for the scan -> body distance.

    Returns
    -------
    dict with ``body_to_scan_mm`` (mean over seen vertices), ``scan_to_body_mm`` (mean),
    ``scan_to_body_p95_mm``, ``outside_share`` (fraction of seen vertices more than
    ``outside_mm`` outside), ``max_part_outside_mm`` (largest per-part 90th percentile of
    the outside distance), ``seen_share`` and ``parts``: {part: {"body_to_scan_mm",
    "outside_p90_mm", "outside_share"}}.
    """
    V = np.asarray(body_vertices, dtype=np.float64)
    F = np.asarray(body_faces, dtype=np.int64)
    P = np.asarray(scan_points, dtype=np.float64)
    d_b2s, nn = cKDTree(P).query(V, k=1, workers=1)
    seen = d_b2s <= seen_radius
    N = vertex_normals(V, F)
    signed = ((V - P[nn]) * N).sum(1)  # > 0: body outside the scan
    outside = np.clip(signed, 0, None) * 1000.0
    samples = sample_surface(V, F, n_samples, seed=seed)[0]
    d_s2b, _ = cKDTree(samples).query(P, k=1, workers=1)
    res = {
        "body_to_scan_mm": float(1000 * d_b2s[seen].mean()) if seen.any() else float("nan"),
        "scan_to_body_mm": float(1000 * d_s2b.mean()),
        "scan_to_body_p95_mm": float(1000 * np.percentile(d_s2b, 95)),
        "outside_share": float((outside[seen] > outside_mm).mean()) if seen.any() else 0.0,
        "seen_share": float(seen.mean()),
        "parts": {},
    }
    worst = 0.0
    if parts is not None:
        for k, name in enumerate(BODY_PARTS):
            sel = (parts == k) & seen
            if not sel.any():
                continue
            p90 = float(np.percentile(outside[sel], 90))
            worst = max(worst, p90)
            res["parts"][name] = {"body_to_scan_mm": float(1000 * d_b2s[sel].mean()),
                                  "outside_p90_mm": p90,
                                  "outside_share": float((outside[sel] > outside_mm).mean())}
    res["max_part_outside_mm"] = worst
    return res


def format_metrics(m: dict) -> str:
    """Human-readable lines (mm) of :func:`fit_metrics` output, worst parts flagged."""
    seen = 100 * m["seen_share"]
    lines = [(f"body -> scan {m['body_to_scan_mm']:.1f} mm (mean over the {seen:.0f}% of the "
              f"body the scan sees), scan -> body {m['scan_to_body_mm']:.1f} mm "
              f"(95th percentile {m['scan_to_body_p95_mm']:.1f} mm)"),
             (f"body outside the scan by > 15 mm: {100 * m['outside_share']:.1f}% of the body; "
              f"worst part {m['max_part_outside_mm']:.1f} mm (90th percentile)")]
    if m.get("parts"):
        lines.append(f"{'part':<16}{'body->scan mm':>14}{'outside p90 mm':>16}")
        for name, p in m["parts"].items():
            flag = "  <- check" if p["outside_p90_mm"] > 15 or p["body_to_scan_mm"] > 30 else ""
            lines.append(f"{name:<16}{p['body_to_scan_mm']:>14.1f}{p['outside_p90_mm']:>16.1f}{flag}")
    return "\n".join(lines)
