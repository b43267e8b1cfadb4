"""Pictures of a method's items for the report site: per task, load the prediction, its
ground truth (and the target body) and draw them (:mod:`dressmeup.viz.result_images`,
:mod:`dressmeup.viz.uv_checker`)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from dressmeup.bench.tasks.fusion.data import read_mesh
from dressmeup.bench.tasks.retarget.data import open_dataset, read_prediction
from dressmeup.bench.tasks.retarget.evaluate import posed_body_file
from dressmeup.io.mesh import load_mesh
from dressmeup.viz.result_images import penetrating_faces, render_error_pair, vertex_distances_mm
from dressmeup.viz.site_viewer import ItemView
from dressmeup.viz.uv_checker import render_uv_checker


def file_slug(text: str) -> str:
    """A file-name-safe slug of ``text`` (letters, digits, ``-``, ``_``, ``.``)."""
    return re.sub(r"[^A-Za-z0-9._-]+", "-", text).strip("-.").lower()[:48] or "item"


def _submission_file(sub: Path, item_id: str) -> Path | None:
    for p in sub.iterdir():
        if p.stem == item_id and p.name != "submission.json":
            return p
    return None


def _retarget_arrays(row: dict, sub: Path, root: Path, models: dict) -> dict:
    ds = open_dataset(str(root.resolve()))
    f = _submission_file(sub, row["sample_id"])
    if f is None:
        raise FileNotFoundError(f"{row['sample_id']} not in {sub}")
    V = np.asarray(read_prediction(f)[0], np.float64)
    F = np.asarray(ds[row["source_id"]].garment().faces, np.int64)
    tgt = ds[row["target_id"]]
    g = tgt.garment()
    pen = body_V = body_F = None
    params = tgt.body()
    if params is not None:
        with np.load(posed_body_file(params, models), allow_pickle=False) as z:
            body_V, body_F = np.asarray(z["vertices"], np.float64), np.asarray(z["faces"])
        pen = penetrating_faces(V, F, body_V, body_F)
    verr = vertex_distances_mm(V, g.vertices, g.faces)
    return {"V": V, "F": F, "gt_V": g.vertices, "gt_F": g.faces, "verr": verr,
            "err": verr[F].mean(axis=1), "pen": pen, "body_V": body_V, "body_F": body_F}


def _fusion_arrays(row: dict, sub: Path, root: Path, models: dict) -> dict:
    f = _submission_file(sub, row["sample_id"])
    if f is None:
        raise FileNotFoundError(f"{row['sample_id']} not in {sub}")
    V, F = read_mesh(f)
    scan = open_dataset(str(root.resolve()))[row["sample_id"]].scan()
    if scan is None:
        raise FileNotFoundError(f"sample {row['sample_id']} has no scan")
    F = np.asarray(F, np.int64)
    verr = vertex_distances_mm(V, scan[0], scan[1])
    return {"V": V, "F": F, "gt_V": scan[0], "gt_F": scan[1], "verr": verr,
            "err": verr[F].mean(axis=1), "pen": None, "body_V": None, "body_F": None}


def draw_items(task: str, rows: list[dict], sub: Path, root: Path, img_dir: Path,
                prefix: str, metric_label: str, views: list[ItemView] | None = None
                ) -> list[tuple[Path, str]]:
    """Draw the items ``rows`` of one method.

    Parameters
    ----------
    task : ``retarget`` (prediction vs ground truth, P2S heat map, penetrations red),
        ``uvparam`` (checkerboard render) or ``fusion`` (distance to the scan).
    rows : per-item result rows (dicts with ``sample_id``, ids, ``_caption``).
    sub : the submission folder; root : the dataset root; img_dir : where PNGs go.
    prefix : file-name prefix (method slug and best/worst).
    metric_label : label of the ranked metric (for captions).
    views : when given, one :class:`~dressmeup.viz.site_viewer.ItemView` per drawn
        retarget or fusion item is appended (the 3D view's meshes, full resolution).

    Returns
    -------
    list of (png path, caption), one per drawn item (items without a file are skipped).
    """

    out: list[tuple[Path, str]] = []
    if task == "uvparam":
        # heavy: pandas
        from dressmeup.bench.tasks.uvparam.data import meshes, read_prediction

        paths = {m.mesh_id: m.path for m in meshes(root)}
        for row in rows:
            f = _submission_file(sub, row["sample_id"])
            if f is None or row["sample_id"] not in paths:
                continue
            mesh = load_mesh(paths[row["sample_id"]])
            pred = read_prediction(f)
            F = np.asarray(mesh.faces, np.int64)
            png = img_dir / f"{prefix}-{file_slug(row['sample_id'])}.png"
            render_uv_checker(mesh.vertices, F, pred["uv"], pred.get("uv_faces", F), png,
                              title=row["sample_id"], chart_ids=pred.get("chart_ids"),
                              views=((20, 30),), max_faces=8000, dpi=70)
            out.append((png, row["_caption"]))
        return out
    models: dict = {}
    load = _retarget_arrays if task == "retarget" else _fusion_arrays
    arrays = [(row, load(row, sub, root, models)) for row in rows]
    if not arrays:
        return out
    allerr = np.concatenate([a["err"] for _, a in arrays])
    vmax = float(np.percentile(allerr[np.isfinite(allerr)], 98)) if allerr.size else 1.0
    label = "P2S" if task == "retarget" else "distance to scan"
    for row, a in arrays:
        png = img_dir / f"{prefix}-{file_slug(row['sample_id'])}.png"
        render_error_pair(a["V"], a["F"], a["gt_V"], a["gt_F"], png, face_error_mm=a["err"],
                          vmax_mm=vmax, penetrating=a["pen"], title=row["sample_id"],
                          error_label=label)
        out.append((png, row["_caption"]))
        if views is not None:
            views.append(ItemView(row["_caption"], a["V"], a["F"], a["verr"], a["gt_V"],
                                  a["gt_F"], a["body_V"], a["body_F"]))
    return out


def vmax_of(views: list[ItemView]) -> float:
    """The top of a colour scale shared by ``views``: the 98th percentile of their per-vertex
    errors (mm), 1 when there are none."""
    allerr = np.concatenate([np.asarray(v.vertex_error_mm, float) for v in views]) \
        if views else np.zeros(0)
    allerr = allerr[np.isfinite(allerr)]
    return float(np.percentile(allerr, 98)) if allerr.size else 1.0
