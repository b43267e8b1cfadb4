"""The 3D view of a method page of the report site (:mod:`dressmeup.viz.site`): its best and
worst items turned with the mouse in the browser, drawn by three.js.

For each item: the prediction coloured by its per-vertex error (the distance of each
predicted vertex to the ground-truth surface, mm, computed on the full meshes), the ground
truth and the target body, each toggled by a checkbox and overlaid in the same frame, with
a colour bar and its scale. The meshes are simplified for display only (vertex clustering to
at most :data:`MAX_FACES` faces a garment, :data:`MAX_BODY_FACES` the body; a merged vertex
shows the mean error of the vertices it replaces) and quantised to 16 bits per coordinate.

Nothing is fetched: the page loads, with classic ``<script>`` tags (ES modules do not load
from ``file://`` in Chromium), ``_static/three-<version>.js`` -- the vendored three.js
module build (``vendor/three``, pinned with its sha256 in ``vendor/three/README.md``) turned
into one classic script that defines ``window.THREE`` --, ``img/<slug>-3d.js`` -- the page's
meshes as base64 arrays in ``window.DRESSMEUP_VIEWS`` -- and ``_static/site_viewer.js``.
"""

from __future__ import annotations

import base64
import html
import json
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dressmeup.io.atomic import atomic_write_text
from dressmeup.viz.result_images import ERROR_CMAP

#: The vendored three.js release (``npm pack three@THREE_VERSION``).
THREE_VERSION = "0.187.0"
VENDOR = Path(__file__).with_name("vendor") / "three"
#: The vendored files, in load order.
THREE_FILES = ("three.core.js", "three.module.js", "OrbitControls.js")
#: Faces of one displayed garment (prediction, ground truth) at most.
MAX_FACES = 12_000
#: Faces of the displayed body at most (it is the garments' context).
MAX_BODY_FACES = 6_000

_IMPORT = re.compile(r"^import\s*\{([^}]*)\}\s*from\s*['\"][^'\"]+['\"];?[ \t]*$", re.M)
_REEXPORT = re.compile(r"^export\s*\{[^}]*\}\s*from\s*['\"][^'\"]+['\"];?[ \t]*$", re.M)
_EXPORT = re.compile(r"^export\s*\{([^}]*)\};?[ \t]*$", re.M)


def _names(spec: str) -> list[tuple[str, str]]:
    """``a, b as c`` -> ``[("a", "a"), ("b", "c")]`` (local name, exported name)."""
    out = []
    for part in spec.split(","):
        bits = part.split()
        if bits:
            out.append((bits[0], bits[2]) if len(bits) == 3 and bits[1] == "as"
                       else (bits[0], bits[0]))
    return out


def classic_script(source: str) -> str:
    """An ES module of three.js as a classic script on the global ``THREE``.

    Its ``import {..} from ..`` become reads of ``THREE``, ``export {..} from ..`` (names
    another file already put there) are dropped, and ``export {..}`` assigns to ``THREE``;
    the module body runs in strict mode inside a function, as a module would.

    Raises
    ------
    ValueError
        ``source`` has another kind of import or export (``export default``, ``export *``,
        ``import x from``, an exported declaration), which this conversion does not handle.
    """
    def imp(m: re.Match) -> str:
        return "const { " + ", ".join(f"{exp}: {loc}" if loc != exp else loc
                                      for exp, loc in _names(m.group(1))) + " } = THREE;"

    def exp(m: re.Match) -> str:
        return "Object.assign( THREE, { " + ", ".join(
            f"{name}: {loc}" if loc != name else loc
            for loc, name in _names(m.group(1))) + " } );"

    body = _EXPORT.sub(exp, _REEXPORT.sub("", _IMPORT.sub(imp, source)))
    left = re.findall(r"^\s*(?:import|export)\b.*$", body, re.M)
    if left:
        raise ValueError(f"source: cannot convert the module statement {left[0][:80]!r}")
    return ("( function ( THREE ) {\n'use strict';\n" + body
            + "\n} )( window.THREE = window.THREE || {} );\n")


def three_script() -> str:
    """The vendored three.js with OrbitControls as one classic script (see
    :func:`classic_script`), headed by its licence line."""
    parts = [f"/* three.js {THREE_VERSION} (MIT licence, see vendor/three/LICENSE), "
             "converted to a classic script by dressmeup.viz.site_viewer */"]
    for name in THREE_FILES:
        parts.append(f"/* {name} */\n" + classic_script((VENDOR / name).read_text("utf-8")))
    return "\n".join(parts)


def write_static(site_root: Path) -> tuple[str, str]:
    """Write ``_static/three-<version>.js`` (when missing) and ``_static/site_viewer.js``
    into the site; their paths relative to ``site_root``."""
    static = site_root / "_static"
    static.mkdir(parents=True, exist_ok=True)
    three = static / f"three-{THREE_VERSION}.js"
    if not three.is_file():
        atomic_write_text(three, three_script())
    viewer = static / "site_viewer.js"
    atomic_write_text(viewer, Path(__file__).with_name("site_viewer.js").read_text("utf-8"))
    return f"_static/{three.name}", f"_static/{viewer.name}"


def cluster_simplify(V: np.ndarray, F: np.ndarray, values: np.ndarray | None = None,
                     max_faces: int = MAX_FACES
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Vertex clustering on a grid, coarse enough that at most ``max_faces`` faces remain.

    Parameters
    ----------
    V : (n, 3) float64 vertices; F : (m, 3) int64 faces.
    values : (n,) float64 per-vertex values (e.g. errors), or None.
    max_faces : faces kept at most.

    Returns
    -------
    V2 : (n2, 3) float64, the mean of each cluster's vertices.
    F2 : (m2, 3) int64, m2 <= max_faces, without faces that collapsed or repeat.
    values2 : (n2,) float64, the mean value over each cluster (None when ``values`` is).
    """
    V = np.asarray(V, np.float64)
    F = np.asarray(F, np.int64)
    if len(F) <= max_faces:
        return V, F, None if values is None else np.asarray(values, np.float64)
    lo = V.min(0)
    extent = float(np.ptp(V, axis=0).max()) or 1.0
    cells = max(4, int(np.sqrt(max_faces) * 2))
    while True:
        key = np.floor((V - lo) / (extent / cells)).astype(np.int64)
        _, label = np.unique(key, axis=0, return_inverse=True)
        label = label.reshape(-1)
        G = label[F]
        keep = (G[:, 0] != G[:, 1]) & (G[:, 1] != G[:, 2]) & (G[:, 0] != G[:, 2])
        G = G[keep]
        G = G[np.unique(np.sort(G, axis=1), axis=0, return_index=True)[1]]
        if len(G) <= max_faces or cells <= 4:
            break
        cells = max(4, int(cells * 0.8))
    n = label.max() + 1
    count = np.bincount(label, minlength=n).astype(np.float64)
    V2 = np.stack([np.bincount(label, V[:, k], n) for k in range(3)], axis=1) / count[:, None]
    used = np.unique(G)
    remap = np.full(n, -1, np.int64)
    remap[used] = np.arange(len(used))
    vals = None
    if values is not None:
        vals = (np.bincount(label, np.asarray(values, np.float64), n) / count)[used]
    return V2[used], remap[G], vals


@dataclass
class ItemView:
    """One item of the 3D view (full-resolution meshes; simplified when written).

    Attributes
    ----------
    caption : the item's caption.
    pred_V, pred_F : prediction, (n, 3) float64 metres / (m, 3) int64.
    vertex_error_mm : (n,) float64 distance of each predicted vertex to the ground truth.
    gt_V, gt_F : the ground truth (or, for fusion, the scan).
    body_V, body_F : the target body, or None.
    """

    caption: str
    pred_V: np.ndarray
    pred_F: np.ndarray
    vertex_error_mm: np.ndarray
    gt_V: np.ndarray
    gt_F: np.ndarray
    body_V: np.ndarray | None = None
    body_F: np.ndarray | None = None


def _b64(a: np.ndarray) -> str:
    return base64.b64encode(np.ascontiguousarray(a).tobytes()).decode("ascii")


def _mesh(V: np.ndarray, F: np.ndarray, lo: np.ndarray, step: np.ndarray,
          max_faces: int, values: np.ndarray | None = None) -> dict:
    V2, F2, vals = cluster_simplify(V, F, values, max_faces)
    q = np.clip(np.round((V2 - lo) / step), 0, 65535).astype("<u2")
    big = len(V2) > 65535
    out = {"n": int(len(V2)), "m": int(len(F2)), "pos": _b64(q),
           "idx": _b64(F2.astype("<u4" if big else "<u2")), "idx32": big}
    if vals is not None:
        out["err"] = _b64(np.nan_to_num(vals, nan=0.0).astype("<f4"))
    return out


def view_data(items: list[ItemView], vmax_mm: float, error_label: str, truth_label: str,
              max_faces: int = MAX_FACES) -> dict:
    """The JSON-able data of a page's 3D view: per item, its meshes simplified and quantised
    (positions: uint16 over the item's box; faces: uint16/uint32; errors: float32 mm), and
    the colour scale (``vmax_mm``, the 256 colours of the error colour map)."""
    # heavy: matplotlib (~0.3 s to import)
    from matplotlib import colormaps

    lut = (colormaps[ERROR_CMAP](np.linspace(0, 1, 256))[:, :3] * 255).round().astype(np.uint8)
    out = []
    for it in items:
        parts = [it.pred_V, it.gt_V] + ([it.body_V] if it.body_V is not None else [])
        allv = np.vstack([np.asarray(p, np.float64) for p in parts])
        lo, hi = allv.min(0), allv.max(0)
        step = np.maximum(hi - lo, 1e-9) / 65535.0
        entry = {"caption": it.caption, "lo": lo.tolist(), "step": step.tolist(),
                 "pred": _mesh(it.pred_V, it.pred_F, lo, step, max_faces,
                               np.asarray(it.vertex_error_mm, np.float64)),
                 "gt": _mesh(it.gt_V, it.gt_F, lo, step, max_faces)}
        if it.body_V is not None:
            entry["body"] = _mesh(it.body_V, it.body_F, lo, step,
                                  min(max_faces, MAX_BODY_FACES))
        out.append(entry)
    return {"vmax": float(vmax_mm), "unit": "mm", "error_label": error_label,
            "truth_label": truth_label, "lut": _b64(lut), "items": out}


def write_view(items: list[ItemView], vmax_mm: float, error_label: str, truth_label: str,
               img_dir: Path, slug: str) -> str:
    """Write the page's 3D data (``img_dir/<slug>-3d.js``) and the shared scripts; return
    the HTML of the view (for a page in ``img_dir``'s parent, one level below the site
    root)."""
    e = html.escape
    data = view_data(items, vmax_mm, error_label, truth_label)
    js = img_dir / f"{slug}-3d.js"
    img_dir.mkdir(parents=True, exist_ok=True)
    # json.dumps escapes nothing HTML-special, but a .js file is never parsed as HTML
    atomic_write_text(js, "window.DRESSMEUP_VIEWS = " + json.dumps(data) + ";\n")
    three, viewer = write_static(img_dir.parent.parent)
    options = "".join(f'<option value="{i}">{e(it.caption)}</option>'
                      for i, it in enumerate(items))
    body_box = ('<label><input type="checkbox" data-layer="body" checked> target body</label>'
                if any(it.body_V is not None for it in items) else "")
    faces = max(max(d["pred"]["m"], d["gt"]["m"], d.get("body", {}).get("m", 0))
                for d in data["items"])
    return f"""<h3>In 3D</h3>
<div class="viewer3d" id="viewer3d">
<div class="v3d-controls">
<label>item <select class="v3d-item">{options}</select></label>
<label><input type="checkbox" data-layer="pred" checked> prediction (colour: {e(error_label)})</label>
<label><input type="checkbox" data-layer="gt"> {e(truth_label)}</label>
{body_box}
</div>
<canvas class="v3d-canvas" width="760" height="520"></canvas>
<div class="v3d-bar"><span class="v3d-bar-title">{e(error_label)} [mm]</span>
<span class="v3d-scale"><canvas class="v3d-cbar" width="256" height="14"></canvas>
<span class="v3d-ticks"><span>0</span><span>{vmax_mm / 2:.1f}</span><span>&ge; {vmax_mm:.1f}</span></span>
</span></div>
<p class="meta">Drag to turn, wheel to zoom, right-drag to move. Colour: the distance of each
predicted vertex to the {e(truth_label)} surface, computed on the full meshes, on one scale
for every item of this view (top: the 98th percentile of their errors); the meshes are
simplified for display (here to {faces:,} faces at most).</p>
<p class="v3d-status meta"></p>
</div>
<script src="../{three}"></script>
<script src="img/{e(js.name)}"></script>
<script src="../{viewer}"></script>"""
