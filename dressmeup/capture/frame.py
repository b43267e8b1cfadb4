"""One camera's images at one time, and the camera that took them."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from dressmeup.capture.camera import Camera
from dressmeup.capture.rig import Rig
from dressmeup.errors import InputError

__all__ = ["RGBDFrame", "frame_camera", "with_rig_cameras"]


@dataclass
class RGBDFrame:
    """One camera's images at one time.

    Attributes
    ----------
    serial : str
    index : int, frame number.
    color : (h, w, 3) uint8 RGB.
    depth : (h, w) float32 metres, 0 where there is no measurement.
    labels : (h, w) uint8 label mask, or None.
    camera : the calibrated camera that took it, or None (then :func:`frame_camera` looks it
        up in a rig by serial). Set by ``Session.load_frame`` (the session's rig),
        ``render_frames`` (the rendering rig) and :func:`with_rig_cameras` (another
        calibration); fusion reads it and, after refinement, attaches the refined camera.
    """

    serial: str
    index: int
    color: np.ndarray
    depth: np.ndarray
    labels: np.ndarray | None = None
    camera: Camera | None = None


def frame_camera(frame: RGBDFrame, rig: Rig | None = None) -> Camera:
    """The camera of a frame: the one it carries, else ``rig``'s camera of its serial.

    Raises
    ------
    InputError
        When the frame carries no camera and no rig is given.
    """
    if frame.camera is not None:
        return frame.camera
    if rig is None:
        raise InputError(f"frame {frame.serial}/{frame.index} carries no camera and no rig was given")
    return rig.camera(frame.serial)


def with_rig_cameras(frames: list[RGBDFrame], rig: Rig) -> list[RGBDFrame]:
    """The frames, each carrying ``rig``'s camera of its serial (another calibration).

    Parameters
    ----------
    frames : list of RGBDFrame
    rig : Rig with a camera for every frame's serial.

    Returns
    -------
    list of RGBDFrame (copies; the images are shared, not copied).

    Raises
    ------
    InputError naming a serial the rig lacks.
    """
    out = []
    for fr in frames:
        try:
            cam = rig.camera(fr.serial)
        except KeyError as exc:
            raise InputError(f"frame {fr.serial}/{fr.index}: {exc.args[0]}") from exc
        out.append(replace(fr, camera=cam))
    return out
