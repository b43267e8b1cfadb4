"""Body models (docs/spec.md section 2): protocol, the open default model, a procedural test
body, SMPL-family models from user files, body parameter files, registration, skinning.

>>> from dressmeup.body import get_body_model, BodyParams
>>> model = get_body_model("procedural")
>>> out = model.posed(model.default_params())      # numpy, one body
>>> out.vertices.shape == (model.n_vertices, 3)
True

Heavy dependencies (torch, anny) are imported only when a model is built or run.
"""

from __future__ import annotations

from dressmeup.body.base import BodyModel, BodyOutput, LBSBodyModel
from dressmeup.body.models import available_body_models, get_body_model, register_body_model
from dressmeup.body.params import BodyParams
from dressmeup.body.skeleton import PHENOTYPE_NAMES, SMPL22_JOINT_NAMES, SMPL22_PARENTS

__all__ = [
    "BodyModel",
    "BodyOutput",
    "BodyParams",
    "LBSBodyModel",
    "PHENOTYPE_NAMES",
    "SMPL22_JOINT_NAMES",
    "SMPL22_PARENTS",
    "available_body_models",
    "get_body_model",
    "register_body_model",
]
