"""A static indoor scene and a hand-held sensor walking through it (moving-sensor captures).

The scene is what makes real RGB-D sequences hard for extrinsic refinement: a floor and
walls (large planes ICP can slide along) around a few boxes and the mannequin, with a
procedural texture; the kitchen adds the repetitive geometry of real rooms (a counter, a
wall of shelves, a table on thin legs, a tall cupboard) and has no mannequin. The sensor is a Kinect v1-like VGA camera (525 px focal length) moving
on an arc while looking at the middle of the room; each frame is one camera of the rig, as
an imported dataset session has it.
"""

from __future__ import annotations

import math

import numpy as np

from dressmeup.capture.camera import Camera
from dressmeup.capture.rig import Rig, look_at
from dressmeup.capture.synthetic.subject import SyntheticSubject, make_mannequin

__all__ = ["make_kitchen", "make_room", "walk_rig"]


def _box(lo: np.ndarray, hi: np.ndarray, inward: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and outward (or inward) faces of an axis-aligned box."""
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    V = np.array([[x0, y0, z0], [x1, y0, z0], [x1, y1, z0], [x0, y1, z0],
                  [x0, y0, z1], [x1, y0, z1], [x1, y1, z1], [x0, y1, z1]], float)
    F = np.array([[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7], [0, 1, 5], [0, 5, 4],
                  [3, 7, 6], [3, 6, 2], [0, 4, 7], [0, 7, 3], [1, 2, 6], [1, 6, 5]])
    return V, (F[:, ::-1] if inward else F)


def _subdivide(V: np.ndarray, F: np.ndarray, max_edge: float) -> tuple[np.ndarray, np.ndarray]:
    import trimesh  # heavy: trimesh

    v, f = trimesh.remesh.subdivide_to_size(V, F, max_edge=max_edge)
    return np.asarray(v, float), np.asarray(f, np.int64)


def _texture(points: np.ndarray, face_ids: np.ndarray) -> np.ndarray:
    """A 10 cm checker with a slow colour ramp: enough texture for coloured ICP."""
    c = np.floor(points / 0.1).astype(np.int64).sum(axis=1) % 2
    ramp = 0.5 + 0.3 * np.sin(points @ np.array([1.3, 0.7, 2.1]))
    return np.stack([0.35 + 0.4 * c, ramp, 0.6 - 0.3 * c], axis=1)


def make_room(size: tuple[float, float, float] = (4.0, 2.6, 4.0), seed: int = 0) -> SyntheticSubject:
    """A room (floor, ceiling, four walls, seen from inside) with boxes and the mannequin.

    Parameters
    ----------
    size : (x, y, z) metres; y is up, the floor at y = 0, the room centred on x = z = 0.
    seed : int, seed of the mannequin.

    Returns
    -------
    SyntheticSubject (face label 1 everywhere but the mannequin's own labels).
    """
    sx, sy, sz = size
    parts = [_box(np.array([-sx / 2, 0, -sz / 2]), np.array([sx / 2, sy, sz / 2]), inward=True),
             _box(np.array([0.6, 0.0, -0.9]), np.array([1.3, 0.75, -0.2])),
             _box(np.array([-1.4, 0.0, -1.2]), np.array([-0.8, 1.1, -0.7])),
             _box(np.array([-0.5, 0.0, 0.8]), np.array([0.2, 0.45, 1.3]))]
    Vs, Fs, labels, off = [], [], [], 0
    for V, F in parts:
        V, F = _subdivide(V, F, 0.25)
        Vs.append(V)
        Fs.append(F + off)
        labels.append(np.ones(len(F), np.uint8))
        off += len(V)
    man = make_mannequin(seed=seed)
    mv = man.vertices - [man.vertices[:, 0].mean(), man.vertices[:, 1].min(), man.vertices[:, 2].mean()]
    Vs.append(mv)
    Fs.append(man.faces + off)
    labels.append(man.face_labels)
    return SyntheticSubject(np.concatenate(Vs), np.concatenate(Fs), np.concatenate(labels), man.garments,
                            color_fn=_texture, subject_id="room", pose_id="P0")


def _mesh(parts: list[tuple[np.ndarray, np.ndarray]]) -> tuple[np.ndarray, np.ndarray]:
    """One mesh of boxes, subdivided to 25 cm edges (the renderer's rays hit small triangles)."""
    Vs, Fs, off = [], [], 0
    for V, F in parts:
        V, F = _subdivide(V, F, 0.25)
        Vs.append(V)
        Fs.append(F + off)
        off += len(V)
    return np.concatenate(Vs), np.concatenate(Fs)


def make_kitchen(size: tuple[float, float, float] = (4.0, 2.6, 4.0)) -> SyntheticSubject:
    """A kitchen (floor, ceiling, four walls, seen from inside): a counter and a wall of four
    shelves along the back wall, a table on four legs, a tall cupboard; no mannequin.

    Parameters
    ----------
    size : (x, y, z) metres; y is up, the floor at y = 0, the room centred on x = z = 0
        (the furniture stands at fixed places near the back wall, z = -size[2] / 2).

    Returns
    -------
    SyntheticSubject (face label 1 everywhere, no garments).
    """
    sx, sy, sz = size
    back = -sz / 2
    box = _box
    parts = [box(np.array([-sx / 2, 0, back]), np.array([sx / 2, sy, sz / 2]), inward=True),
             box(np.array([-1.9, 0, back]), np.array([1.0, 0.9, back + 0.6])),  # counter
             box(np.array([1.4, 0, -1.0]), np.array([1.9, 2.0, 0.2])),  # cupboard
             box(np.array([-0.4, 0.72, -0.9]), np.array([0.8, 0.76, -0.1]))]  # table top
    parts += [box(np.array([x, 1.2, back]), np.array([x + 0.02, 2.2, back + 0.3])) for x in (-1.5, -0.3)]
    parts += [box(np.array([-1.5, y, back]), np.array([-0.28, y + 0.02, back + 0.3])) for y in (1.2, 1.5, 1.8, 2.1)]
    parts += [box(np.array([x, 0, z]), np.array([x + 0.05, 0.72, z + 0.05]))
              for x in (-0.35, 0.7) for z in (-0.85, -0.2)]  # table legs
    V, F = _mesh(parts)
    return SyntheticSubject(V, F, np.ones(len(F), np.uint8), [], color_fn=_texture,
                            subject_id="kitchen", pose_id="P0")


def walk_rig(n_frames: int = 12, radius: float = 1.6, height: float = 1.4, sweep_deg: float = 60.0,
             width: int = 640, height_px: int = 480, focal: float = 525.0) -> Rig:
    """A moving sensor: ``n_frames`` cameras on an arc around the room's centre, looking at it.

    Parameters
    ----------
    n_frames : int. radius : float, metres from the vertical axis. height : float, metres.
    sweep_deg : float, the arc's angle. width, height_px, focal : the VGA camera (Kinect v1).

    Returns
    -------
    Rig with serials ``frame-000000`` ... (y up, the first frame is the reference).
    """
    cams = []
    for k in range(n_frames):
        a = math.radians(-sweep_deg / 2 + sweep_deg * k / max(n_frames - 1, 1))
        eye = np.array([radius * math.sin(a), height + 0.05 * math.sin(3 * a), radius * math.cos(a)])
        target = np.array([0.1 * math.sin(2 * a), 0.8, -0.6])
        cams.append(Camera(f"frame-{k:06d}", width, height_px, focal, focal, (width - 1) / 2, (height_px - 1) / 2,
                           camera_to_world=look_at(eye, target, [0, 1, 0])))
    return Rig(cameras=cams, name="walk", up=np.array([0.0, 1.0, 0.0]), target=np.array([0.0, 0.8, -0.6]))
