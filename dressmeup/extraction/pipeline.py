"""Fused scan -> labelled scan -> one textured garment mesh per garment worn."""

from __future__ import annotations

import logging
import os
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from dressmeup.capture.session import LABEL_SKIN, GarmentInfo, SessionInfo
from dressmeup.extraction.cutout import cut_garment
from dressmeup.extraction.labels import LabelConfig, cluster_colors, label_mesh
from dressmeup.extraction.texture import bake_texture, rasterize_uv, uv_atlas
from dressmeup.fusion.cleanup import CleanupConfig, cleanup_mesh
from dressmeup.fusion.pipeline import FusionResult
from dressmeup.io.mesh import save_mesh

__all__ = ["ExtractionConfig", "ExtractedGarment", "Extraction", "extract_garments", "save_garment"]

log = logging.getLogger(__name__)


@dataclass
class ExtractionConfig:
    """Garment extraction settings.

    Attributes
    ----------
    labels : LabelConfig
    min_component_fraction : float, garment pieces smaller than this share of the largest are dropped.
    boundary_smoothing : int, iterations of boundary-loop smoothing.
    target_faces : int or None, decimate each garment to this many faces before UV mapping
        (xatlas time grows quickly with the face count; None keeps the TSDF resolution).
    texture : bool, build a UV atlas and bake a texture.
    texture_size : int, texture side in texels.
    color_fallback : bool, when the session has no label masks, separate garments by colour
        clustering (with a warning) instead of failing.
    seed : int
    """

    labels: LabelConfig = field(default_factory=LabelConfig)
    min_component_fraction: float = 0.05
    boundary_smoothing: int = 5
    target_faces: int | None = 20000
    texture: bool = True
    texture_size: int = 1024
    color_fallback: bool = True
    seed: int = 0


@dataclass
class ExtractedGarment:
    """One garment cut out of a scan.

    Attributes
    ----------
    info : GarmentInfo
    vertices : (n, 3) float64, faces : (m, 3) int64.
    uv : (k, 2) float64 or None, uv_faces : (m, 3) int64 or None, texture : (s, s, 3) uint8 or None.
    texture_coverage : float, share of atlas texels some camera saw.
    """

    info: GarmentInfo
    vertices: np.ndarray
    faces: np.ndarray
    uv: np.ndarray | None = None
    uv_faces: np.ndarray | None = None
    texture: np.ndarray | None = None
    texture_coverage: float = 0.0


@dataclass
class Extraction:
    """Result of :func:`extract_garments`: scan face labels, garments, and how labels were found."""

    face_labels: np.ndarray
    garments: list[ExtractedGarment]
    method: str  # "masks" or "color-clustering"


def extract_garments(fusion: FusionResult, info: SessionInfo, config: ExtractionConfig | None = None
                     ) -> Extraction:
    """Label the fused scan and cut out, UV-map and texture every garment of the session.

    Parameters
    ----------
    fusion : FusionResult (its frames and rig are used for voting and texturing).
    info : SessionInfo (garment ids, categories and label values).
    config : ExtractionConfig

    Returns
    -------
    Extraction

    Raises
    ------
    ValueError when the session has no label masks and ``color_fallback`` is off, or a
    garment was never seen.
    """

    cfg = config or ExtractionConfig()
    n_labels = max([LABEL_SKIN, *[g.label for g in info.garments]]) + 1
    frames = [f for f in fusion.frames]
    if any(f.labels is not None for f in frames):
        fl = label_mesh(fusion.vertices, fusion.faces, frames, fusion.rig, n_labels, cfg.labels)
        method = "masks"
    elif cfg.color_fallback:
        order = sorted(info.garments, key=lambda g: {"topwear": 0, "dress": 1, "bottomwear": 2}.get(g.category, 3))
        with warnings.catch_warnings():
            warnings.simplefilter("always")
            fl = cluster_colors(fusion.vertices, fusion.faces, fusion.colors, [g.label for g in order],
                                up=fusion.rig.up, seed=cfg.seed, config=cfg.labels)
        log.warning("no label masks in the session: garments separated by colour clustering "
                    "(unreliable for skin-coloured, patterned or similar-coloured garments)")
        method = "color-clustering"
    else:
        raise ValueError("the session has no label masks (SERIAL/labels/*.png); provide masks or "
                         "allow the colour-clustering fallback")
    out = []
    for g in info.garments:
        V, F, _ = cut_garment(fusion.vertices, fusion.faces, fl, g.label, cfg.min_component_fraction,
                              cfg.boundary_smoothing)
        if cfg.target_faces and len(F) > cfg.target_faces:
            V, F, _ = cleanup_mesh(V, F, None, CleanupConfig(min_component_fraction=0.0, max_hole_edges=0,
                                                            repair_non_manifold=True,
                                                            target_faces=cfg.target_faces))
        eg = ExtractedGarment(g, V, F)
        if cfg.texture:
            uv, uvf = uv_atlas(V, F, cfg.texture_size)
            tex, cov = bake_texture(V, F, uv, uvf, frames, fusion.rig, cfg.texture_size,
                                    occluders=(fusion.vertices, fusion.faces))
            eg.uv, eg.uv_faces, eg.texture = uv, uvf, tex
            atlas_mask = rasterize_uv(uv, uvf, cfg.texture_size)[0] >= 0
            eg.texture_coverage = float((cov & atlas_mask).sum() / max(1, atlas_mask.sum()))
        out.append(eg)
    return Extraction(np.asarray(fl, dtype=np.int64), out, method)


def save_garment(garment: ExtractedGarment, folder: str | os.PathLike, transform: np.ndarray | None = None) -> Path:
    """Write ``garment.obj`` (+ ``garment.mtl`` and ``garment.png`` when textured) in ``folder``.

    Parameters
    ----------
    garment : ExtractedGarment
    folder : output folder.
    transform : (4, 4) float or None, rigid transform applied to the vertices first.

    Returns
    -------
    Path of the OBJ file.
    """

    V = garment.vertices
    if transform is not None:
        V = V @ transform[:3, :3].T + transform[:3, 3]
    return save_mesh(Path(folder) / "garment.obj", V, garment.faces, uv=garment.uv,
                     uv_faces=garment.uv_faces, texture=garment.texture)
