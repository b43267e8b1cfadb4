"""The exact answer of a synthetic session, ``SESSION/ground_truth/``: the clothed scan with its
face labels and placement (``scan.npz``) and the true calibration (``rig_true.json``)."""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from dressmeup.capture.rig import Rig, load_rig, save_rig
from dressmeup.io.atomic import atomic_path, atomic_write_text

__all__ = ["GroundTruth", "load_ground_truth", "write_ground_truth"]


@dataclass
class GroundTruth:
    """The exact answer of a synthetic session (``SESSION/ground_truth``).

    Attributes
    ----------
    vertices : (n, 3) float64, faces : (m, 3) int64, the clothed scan in world coordinates.
    face_labels : (m,) uint8
    rig : Rig, the true (unperturbed) calibration.
    subject_to_world : (4, 4) float64
    """

    vertices: np.ndarray
    faces: np.ndarray
    face_labels: np.ndarray
    rig: Rig
    subject_to_world: np.ndarray = field(default_factory=lambda: np.eye(4))

    def garment(self, label: int) -> tuple[np.ndarray, np.ndarray]:
        """The ground-truth garment with this label: (V (k,3) float64, F (l,3) int64)."""
        sel = self.faces[self.face_labels == label]
        used, inv = np.unique(sel, return_inverse=True)
        return self.vertices[used], inv.reshape(-1, 3).astype(np.int64)


def load_ground_truth(session_root: str | os.PathLike) -> GroundTruth:
    """Read ``SESSION/ground_truth`` written by :func:`synth_capture`.

    Raises
    ------
    FileNotFoundError when the session has no ground truth (a real capture).
    """

    gt = Path(session_root) / "ground_truth"
    if not (gt / "scan.npz").is_file():
        raise FileNotFoundError(f"{gt / 'scan.npz'}: no ground truth (only synthetic sessions have one)")
    with np.load(gt / "scan.npz", allow_pickle=False) as z:
        V, F, L, T = z["vertices"], z["faces"], z["face_labels"], z["subject_to_world"]
    return GroundTruth(V.astype(np.float64), F.astype(np.int64), L.astype(np.uint8),
                       load_rig(gt / "rig_true.json"), T.astype(np.float64))


def write_ground_truth(session_root: str | os.PathLike, vertices: np.ndarray, faces: np.ndarray,
                       face_labels: np.ndarray, rig: Rig, subject_to_world: np.ndarray,
                       label_names: dict) -> Path:
    """Write ``SESSION/ground_truth/``: ``scan.npz``, ``rig_true.json``, ``labels.json`` and a
    ``README.txt`` saying what they are (read back by :func:`load_ground_truth`).

    Parameters
    ----------
    session_root : the session folder.
    vertices : (n, 3) float, faces : (m, 3) int, face_labels : (m,) uint8, the clothed scan in
        world coordinates.
    rig : Rig, the true calibration used for rendering.
    subject_to_world : (4, 4) float, how the subject was placed.
    label_names : label value -> name (``SessionInfo.label_names()``).

    Returns
    -------
    Path of the ``ground_truth`` folder.
    """
    gt = Path(session_root) / "ground_truth"
    gt.mkdir(exist_ok=True)
    save_rig(rig, gt / "rig_true.json")
    with atomic_path(gt / "scan.npz") as tmp:
        np.savez_compressed(tmp, vertices=vertices, faces=faces, face_labels=face_labels,
                            subject_to_world=subject_to_world)
    atomic_write_text(gt / "README.txt", "Exact ground truth of this synthetic capture: scan.npz "
                      "(vertices, faces, face_labels, subject_to_world) and rig_true.json (the "
                      "calibration used for rendering; rig.json may hold a perturbed one).\n")
    atomic_write_text(gt / "labels.json", json.dumps(label_names, indent=2) + "\n")
    return gt
