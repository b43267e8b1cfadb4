"""Synthetic RGBD captures with exact ground truth: ray-cast rendering and a depth-noise model.

A :class:`SyntheticSubject` is a labelled, coloured triangle mesh (the clothed person: face
labels 1 = skin, 2.. = garments). :func:`render_frames` ray-casts it from every camera of a
rig with open3d's ``RaycastingScene`` (lens distortion included) and produces colour, depth
and label images; :class:`NoiseModel` turns the exact depth into Kinect-like measurements;
:func:`synth_capture` writes a whole session with its ``ground_truth/`` folder.
"""

from __future__ import annotations

import os
from dataclasses import asdict
from pathlib import Path

import numpy as np

from dressmeup.capture.rig import Rig, perturb_rig
from dressmeup.capture.session import SessionInfo, write_frame, write_session
from dressmeup.capture.synthetic.ground_truth import (
    GroundTruth,
    load_ground_truth,
    write_ground_truth,
)
from dressmeup.capture.synthetic.noise import NoiseModel
from dressmeup.capture.synthetic.render import camera_rays, render_depth, render_frames
from dressmeup.capture.synthetic.subject import (
    ColorFn,
    SyntheticSubject,
    label_faces_by_garments,
    make_mannequin,
    place_subject,
    subject_from_sample,
)

__all__ = [
    "SyntheticSubject",
    "ColorFn",
    "NoiseModel",
    "make_mannequin",
    "subject_from_sample",
    "label_faces_by_garments",
    "place_subject",
    "camera_rays",
    "render_frames",
    "render_depth",
    "synth_capture",
    "load_ground_truth",
    "GroundTruth",
    "write_ground_truth",
]


def synth_capture(subject: SyntheticSubject, rig: Rig, out: str | os.PathLike,
                  noise: NoiseModel | None = None, seed: int = 0, n_frames: int = 1,
                  perturb_deg: float = 0.0, perturb_m: float = 0.0, subject_up: str = "auto",
                  place: bool = True) -> Path:
    """Render a subject with a rig and write a capture session with its ground truth.

    Parameters
    ----------
    subject : SyntheticSubject
    rig : Rig, the true calibration used for rendering.
    out : session folder to write.
    noise : NoiseModel or None (exact depth).
    seed : int, seed of the noise and of the extrinsic perturbation.
    n_frames : int, number of frames (same pose, fresh noise).
    perturb_deg, perturb_m : float, size of the calibration drift written into rig.json
        (every camera but the reference), see :func:`perturb_rig`.
    subject_up : how to find the subject's up axis when placing it (:func:`place_subject`).
    place : stand the subject in the rig (False: use its coordinates as world coordinates).

    Returns
    -------
    Path of the session folder.
    """
    out = Path(out)
    if n_frames < 1:
        raise ValueError(f"n_frames: expected >= 1, got {n_frames}")
    T = np.eye(4)
    if place:
        subject, T = place_subject(subject, rig, subject_up)
    written_rig = perturb_rig(rig, perturb_deg, perturb_m, seed) if (perturb_deg or perturb_m) else rig
    info = SessionInfo(subject_id=subject.subject_id, pose_id=subject.pose_id, garments=subject.garments,
                       n_frames=n_frames,
                       extra={"synthetic": True, "seed": seed, "noise": asdict(noise) if noise else None,
                              "perturbation": {"rotation_deg": perturb_deg, "translation_m": perturb_m}})
    write_session(out, written_rig, info)
    for i in range(n_frames):
        for fr in render_frames(subject, rig, noise, seed=seed, index=i):
            write_frame(out, fr, depth_scale=rig.camera(fr.serial).depth_scale)
    write_ground_truth(out, subject.vertices, subject.faces, subject.face_labels, rig, T,
                       info.label_names())
    return out
