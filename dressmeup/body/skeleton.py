"""The 22-joint SMPL-like skeleton shared by the open body models (docs/spec.md section 2).

Joint order and parents follow the first 22 joints of SMPL. ``pose`` arrays for the open
models are ``(22, 3)`` axis-angle vectors, each joint relative to its parent, with
``pose[0]`` the global orientation of the pelvis.
"""

from __future__ import annotations

import numpy as np

SMPL22_JOINT_NAMES: tuple[str, ...] = (
    "pelvis",
    "left_hip",
    "right_hip",
    "spine1",
    "left_knee",
    "right_knee",
    "spine2",
    "left_ankle",
    "right_ankle",
    "spine3",
    "left_foot",
    "right_foot",
    "neck",
    "left_collar",
    "right_collar",
    "head",
    "left_shoulder",
    "right_shoulder",
    "left_elbow",
    "right_elbow",
    "left_wrist",
    "right_wrist",
)

#: Parent index of every joint (-1 for the root), in :data:`SMPL22_JOINT_NAMES` order.
SMPL22_PARENTS: np.ndarray = np.array(
    [-1, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 9, 9, 12, 13, 14, 16, 17, 18, 19], dtype=np.int64
)

#: Phenotype shape vector of the open models, in order; each in [0, 1], 0.5 is average.
PHENOTYPE_NAMES: tuple[str, ...] = ("gender", "age", "muscle", "weight", "height", "proportions")
