"""The default open body model: ``anny`` (Apache-2.0 code, CC0 MakeHuman data) behind the
:class:`~dressmeup.body.base.BodyModel` protocol.

What this wrapper exposes
-------------------------
- **Skin only**: anny's mesh has 4 connected components (skin, eyes, and small inner
  parts). The model exposes the largest one, re-indexed (13,348 of 13,718 vertices with the
  default topology); ``skin_vertex_ids`` maps back to anny's vertex order.
- **Frame**: anny is Z-up, facing -Y. The wrapper rotates it into the SMPL frame used by
  every model here: Y up, facing +Z, the body's left on +X (``x' = x, y' = z, z' = -y``).
  The origin stays at anny's root (pelvis).
- **Skeleton**: the 22-joint SMPL-like skeleton of docs/spec.md section 2. Each anny bone is
  assigned to one joint (:data:`BONE_GROUPS`); a joint sits at the rest head of its
  anchor bone (the foot joint at the mean of the first toe-bone heads). Skinning weights
  are anny's per-bone weights summed per joint, so the fingers, toes, eyes and twist bones
  follow their joint rigidly. Posing is LBS with these weights, which is exactly anny's own
  skinning with every bone of a group given its joint's transform (:meth:`AnnyBody.anny_pose`
  converts a pose to anny's own pose parameters).
- **Shape**: the phenotype vector ``(gender, age, muscle, weight, height, proportions)``,
  each in [0, 1], 0.5 average; gradients flow to it through anny's blendshapes.

Cache: anny's first build takes one to two minutes and writes about 800 MB. The wrapper
points anny's cache at ``dressmeup.cache.cache_dir("anny")`` (moved with
``DRESSMEUP_CACHE``) and warp's kernel cache at ``cache_dir("warp")`` (unless
``WARP_CACHE_PATH`` is set), then deletes anny's two intermediate files once the compact
model data is written (about 50 MB stay; later builds load in about a second). It never
touches anny's non-commercial (SMPL-topology) data, which would need a download.
"""

from __future__ import annotations

import contextlib
import logging
import os
import sys
import tempfile
import threading
import time
import warnings

import numpy as np

from dressmeup.body.base import LBSBodyModel
from dressmeup.body.skeleton import PHENOTYPE_NAMES, SMPL22_JOINT_NAMES, SMPL22_PARENTS
from dressmeup.cache import cache_dir
from dressmeup.errors import DressmeupError
from dressmeup.progress import working

logger = logging.getLogger(__name__)

#: Rotation from anny's frame (Z up, facing -Y) to the SMPL frame (Y up, facing +Z).
ANNY_TO_SMPL_FRAME = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])

#: Joint -> anny bones it drives (bone-name prefixes; ".L"/".R" for sides). The first bone
#: listed is the anchor whose rest head is the joint (``left_foot``: mean of the toe heads).
BONE_GROUPS: dict[str, tuple[str, ...]] = {
    "pelvis": ("root", "pelvis.L", "pelvis.R", "spine05"),
    "left_hip": ("upperleg01.L", "upperleg02.L"),
    "right_hip": ("upperleg01.R", "upperleg02.R"),
    "spine1": ("spine04", "spine03"),
    "left_knee": ("lowerleg01.L", "lowerleg02.L"),
    "right_knee": ("lowerleg01.R", "lowerleg02.R"),
    "spine2": ("spine02",),
    "left_ankle": ("foot.L",),
    "right_ankle": ("foot.R",),
    "spine3": ("spine01",),
    "left_foot": ("toe*.L",),
    "right_foot": ("toe*.R",),
    "neck": ("neck01", "neck02", "neck03"),
    "left_collar": ("clavicle.L", "shoulder01.L"),
    "right_collar": ("clavicle.R", "shoulder01.R"),
    "head": ("head", "eye.L", "eye.R"),
    "left_shoulder": ("upperarm01.L", "upperarm02.L"),
    "right_shoulder": ("upperarm01.R", "upperarm02.R"),
    "left_elbow": ("lowerarm01.L", "lowerarm02.L"),
    "right_elbow": ("lowerarm01.R", "lowerarm02.R"),
    "left_wrist": ("wrist.L", "finger*.L", "metacarpal*.L"),
    "right_wrist": ("wrist.R", "finger*.R", "metacarpal*.R"),
}

_BUILD_LOCK = threading.Lock()


def _match(label: str, pattern: str) -> bool:
    if "*" in pattern:
        head, tail = pattern.split("*")
        return label.startswith(head) and label.endswith(tail)
    return label == pattern


def bone_to_joint(bone_labels) -> np.ndarray:
    """Map anny bone labels to joint indices of the 22-joint skeleton.

    Parameters
    ----------
    bone_labels : sequence of k anny bone names.

    Returns
    -------
    (k,) int64 joint index per bone.

    Raises
    ------
    DressmeupError : a bone is not covered by :data:`BONE_GROUPS` (a changed anny rig).
    """
    out = np.full(len(bone_labels), -1, dtype=np.int64)
    for j, name in enumerate(SMPL22_JOINT_NAMES):
        for pattern in BONE_GROUPS[name]:
            for b, label in enumerate(bone_labels):
                if out[b] < 0 and _match(label, pattern):
                    out[b] = j
    if (out < 0).any():
        missing = [bone_labels[b] for b in np.flatnonzero(out < 0)]
        raise DressmeupError(f"anny bones not mapped to the 22-joint skeleton: {missing}")
    return out


def _anchor_bones(bone_labels) -> list[list[int]]:
    anchors = []
    for name in SMPL22_JOINT_NAMES:
        first = BONE_GROUPS[name][0]
        if name.endswith("_foot"):  # the ball of the foot: mean of the first toe-bone heads
            ids = [b for b, lab in enumerate(bone_labels) if lab.startswith("toe") and "-1." in lab
                   and lab.endswith(first[-2:])]
        else:
            ids = [b for b, lab in enumerate(bone_labels) if _match(lab, first)]
        if not ids:
            raise DressmeupError(f"anny rig has no bone {first!r} for joint {name!r}")
        anchors.append(ids)
    return anchors


@contextlib.contextmanager
def _no_download():
    """Make any attempt of anny to download its non-commercial data fail loudly."""
    # heavy: anny (~5 s to import, with torch)
    import anny.paths

    original = anny.paths.download_noncommercial_data

    def refuse(*_a, **_k):
        raise DressmeupError("anny tried to download its non-commercial data; dressmeup only "
                             "uses anny's open (CC0) data and never downloads at run time")

    anny.paths.download_noncommercial_data = refuse
    try:
        yield
    finally:
        anny.paths.download_noncommercial_data = original


def _quiet_warp() -> None:
    """Keep warp's initialisation banner (CUDA/devices/kernel cache) off stdout."""
    try:
        # optional: warp (a dependency of anny, not of dressmeup)
        import warp
    except ImportError:  # pragma: no cover - warp is a dependency of anny
        return
    if hasattr(warp, "LOG_WARNING"):
        warp.config.log_level = max(warp.config.log_level, warp.LOG_WARNING)
    else:  # pragma: no cover - warp < 1.12
        warp.config.quiet = True


#: what warp's native code writes to stderr at initialisation on every machine without an
#: NVIDIA driver (it is CPU-only use here, as intended: nothing to act on)
NO_CUDA_NOTICE = "Could not find or load the NVIDIA CUDA driver"


def init_warp_quietly() -> None:
    """Initialise warp with its "no CUDA driver" notice left out of stderr.

    warp's native library prints that notice with ``fprintf(stderr, ...)``, which no
    ``warp.config`` setting silences; so file descriptor 2 is captured for the
    initialisation and everything else it wrote is passed on. Does nothing when warp is
    missing; ``warp.init()`` itself does nothing the second time.
    """

    try:
        # optional: warp (a dependency of anny, not of dressmeup)
        import warp
    except ImportError:  # pragma: no cover - warp is a dependency of anny
        return
    sys.stderr.flush()
    saved = os.dup(2)
    with tempfile.TemporaryFile() as tmp:
        os.dup2(tmp.fileno(), 2)
        try:
            warp.init()
        finally:  # also when init fails: what it wrote is passed on
            os.dup2(saved, 2)
            os.close(saved)
            tmp.seek(0)
            text = tmp.read().decode("utf-8", errors="replace")
            rest = "".join(line for line in text.splitlines(keepends=True)
                           if NO_CUDA_NOTICE not in line)
            if rest:
                sys.stderr.write(rest)


def _configure_caches():
    _quiet_warp()
    if not os.environ.get("WARP_CACHE_PATH"):
        try:
            # optional: warp (a dependency of anny, not of dressmeup)
            import warp

            if getattr(warp.config, "kernel_cache_dir", None) is None:
                warp.config.kernel_cache_dir = str(cache_dir("warp"))
        except ImportError:  # pragma: no cover - warp is a dependency of anny
            pass
    init_warp_quietly()
    # heavy: anny (~5 s to import, with torch)
    import anny.paths

    path = cache_dir("anny")
    anny.paths.set_anny_cache_path(path)
    return path


def _prune_cache(path) -> int:
    """Delete anny's intermediate cache files once the compact model data exists."""
    removed = 0
    for version_dir in path.glob("v*"):
        if not any(version_dir.glob("build_compact_model_data_*.safetensors")):
            continue
        for pattern in ("build_model_data_*.safetensors", "load_data_*.safetensors"):
            for f in version_dir.glob(pattern):
                removed += f.stat().st_size
                f.unlink()
    return removed


def build_anny(prune_cache: bool = True):
    """Build (or load from the cache) anny's default full-body model.

    Returns
    -------
    (anny.Anny model, seconds, cache path).
    """
    with _BUILD_LOCK:
        path = _configure_caches()
        t0 = time.perf_counter()

        # heavy: anny (~5 s to import, with torch)
        import anny

        with _no_download(), warnings.catch_warnings(), working(
                f"building the anny body model (minutes the first time, then read from {path})"):
            warnings.simplefilter("ignore", DeprecationWarning)
            model = anny.Anny(rig="anny", topology="anny", local_changes="none",
                              facial_actions="none", phenotypes="default",
                              pose_parameterization="local-ref")
        seconds = time.perf_counter() - t0
        if prune_cache:
            freed = _prune_cache(path)
            if freed:
                logger.info("anny cache: removed %.0f MB of intermediate files", freed / 2**20)
        logger.info("anny model ready in %.1f s (cache %s)", seconds, path)
        return model, seconds, path


class AnnyBody(LBSBodyModel):
    """The default open body model (see module docstring).

    Parameters
    ----------
    prune_cache : delete anny's large intermediate cache files after the first build.
    """

    name = "anny"

    def __init__(self, prune_cache: bool = True) -> None:
        # heavy: torch (~1.1 s to import)
        import torch

        model, seconds, path = build_anny(prune_cache=prune_cache)
        self.anny = model
        self.build_seconds = seconds
        self.cache_path = path
        labels = list(model.bone_labels)
        self.bone_labels = tuple(labels)
        self.bone_joint = bone_to_joint(labels)
        self._anchors = _anchor_bones(labels)
        faces = model.get_triangular_faces().cpu().numpy().astype(np.int64)
        n_all = int(model.template_vertices.shape[0])
        # heavy: scipy.sparse
        from dressmeup.geometry.topology import largest_component

        self.skin_vertex_ids, self.faces = largest_component(faces, n_all)
        # Skinning weights summed per joint.
        bi = model.vertex_bone_indices.cpu().numpy().astype(np.int64)[self.skin_vertex_ids]
        bw = model.vertex_bone_weights.cpu().numpy().astype(np.float64)[self.skin_vertex_ids]
        W = np.zeros((self.skin_vertex_ids.size, 22))
        np.add.at(W, (np.repeat(np.arange(bi.shape[0]), bi.shape[1]), self.bone_joint[bi.ravel()]),
                  bw.ravel())
        self.skinning_weights = W / W.sum(1, keepdims=True)
        self.joint_names = SMPL22_JOINT_NAMES
        self.joint_parents = SMPL22_PARENTS.copy()
        self.shape_names = PHENOTYPE_NAMES
        self.shape_dim = 6
        self.default_shape = np.full(6, 0.5)
        self._rest_cache: tuple | None = None
        with torch.no_grad():
            V, J = self.rest(torch.as_tensor(self.default_shape[None], dtype=torch.float64))
        self.template_vertices = V[0].numpy()
        self.template_joints = J[0].numpy()

    # ------------------------------------------------------------------ rest
    def _anny_rest(self, shape):
        """Anny rest vertices (b, N, 3) and bone heads (b, 104, 3) in anny's frame."""
        coeffs, heads = self._anny_coefficients(shape)
        return self.anny.get_rest_vertices(coeffs), heads

    def _anny_coefficients(self, shape):
        """Anny's blendshape coefficients (b, c) of phenotype ``shape`` (b, 6) and its bone
        heads (b, 104, 3) in anny's frame."""
        # heavy: anny (~5 s to import, with torch)
        from anny.skinning import skinning

        m = self.anny
        md = m.template_vertices.dtype
        phen = shape.to(md)
        empty = phen.new_zeros(phen.shape[0], 0)
        local = m._parse_parameter_kwargs(None, m.local_change_labels, 0.0, "local_changes_kwargs")
        facial = m._parse_parameter_kwargs(None, m.facial_action_labels, 0.0, "facial_actions")
        if local.shape[0] != phen.shape[0]:
            local = local.expand(phen.shape[0], -1) if local.shape[-1] else empty
        if facial.shape[0] != phen.shape[0]:
            facial = facial.expand(phen.shape[0], -1) if facial.shape[-1] else empty
        coeffs = m._get_phenotype_blendshape_coefficients(phen, local, facial)
        heads = skinning.apply_linear_blendshape(m.template_bone_heads, m.bone_heads_blendshapes,
                                                 coeffs)
        return coeffs, heads

    def rest(self, shape):
        """Shaped rest skin vertices (b, n, 3) and 22 joints (b, 22, 3), SMPL frame.

        The last result is cached for shapes that need no gradient, so repeated poses of one
        body cost only the skinning.
        """
        # heavy: torch (~1.1 s to import)
        import torch

        key = None
        if not shape.requires_grad:
            key = (shape.dtype, str(shape.device), shape.detach().cpu().numpy().tobytes())
            if self._rest_cache is not None and self._rest_cache[0] == key:
                return self._rest_cache[1], self._rest_cache[2]
        verts, heads = self._anny_rest(shape)
        ids = self._buffer("skin_vertex_ids", torch.long, verts.device)
        R = self._buffer("_frame", verts.dtype, verts.device)
        V = verts[:, ids] @ R.T
        J = torch.stack([heads[:, a].mean(1) for a in self._anchors], dim=1) @ R.T
        V, J = V.to(shape.dtype), J.to(shape.dtype)
        if key is not None:
            self._rest_cache = (key, V, J)
        return V, J

    def rest_subset(self, shape, vertex_ids):
        """Rest vertices of ``vertex_ids`` (b, k, 3) and the 22 joints (b, 22, 3), SMPL
        frame. A shape without a gradient takes the (cached) whole rest body; one with a
        gradient blends only those vertices' rows of anny's blendshapes (the same values
        and gradients, a third of the work for registration's 5,000 points)."""
        # heavy: torch (~1.1 s to import)
        import torch

        if not shape.requires_grad:
            V, J = self.rest(shape)
            return V[:, vertex_ids], J
        key = (str(vertex_ids.device), vertex_ids.cpu().numpy().tobytes())
        cached = self.__dict__.get("_subset_blend")
        if cached is None or cached[0] != key:
            m = self.anny
            sel = self._buffer("skin_vertex_ids", torch.long, vertex_ids.device)[vertex_ids]
            cached = self.__dict__["_subset_blend"] = (
                key, m.template_vertices[sel].contiguous(), m.blendshapes[:, sel].contiguous())
        _, template, blendshapes = cached
        coeffs, heads = self._anny_coefficients(shape)
        verts = template[None] + torch.einsum("cpd, bc -> bpd", blendshapes, coeffs)
        R = self._buffer("_frame", verts.dtype, verts.device)
        V = (verts @ R.T).to(shape.dtype)
        J = torch.stack([heads[:, a].mean(1) for a in self._anchors], dim=1) @ R.T
        return V, J.to(shape.dtype)

    def rest_extent(self, shape, axis: int = 1):
        """(b,) extent (m) of the rest skin along SMPL axis ``axis`` for shape (b, 6). The
        frame turn maps that axis onto one of anny's, so only that coordinate is blended
        (the same values as from :meth:`rest`, a quarter of the work)."""
        # heavy: torch (~1.1 s to import)
        import torch

        row = np.asarray(self._frame)[axis]
        src = int(np.flatnonzero(row)[0])
        if np.count_nonzero(row) != 1 or abs(row[src]) != 1.0 or shape.requires_grad:
            return super().rest_extent(shape, axis)
        key = (axis, str(shape.device))
        cached = self.__dict__.get("_extent_blend")
        if cached is None or cached[0] != key:
            m = self.anny
            ids = self._buffer("skin_vertex_ids", torch.long, shape.device)
            cached = self.__dict__["_extent_blend"] = (
                key, m.template_vertices[ids, src].contiguous(),
                m.blendshapes[:, ids, src].contiguous())
        _, template, blendshapes = cached
        coeffs, _ = self._anny_coefficients(shape)
        x = (template[None] + torch.einsum("cp, bc -> bp", blendshapes, coeffs)).to(shape.dtype)
        if row[src] < 0:
            x = -x
        return x.max(1).values - x.min(1).values

    _frame = ANNY_TO_SMPL_FRAME

    # ------------------------------------------------------------ anny side
    def anny_pose(self, shape, pose, parameterization: str = "local-ref"):
        """Convert a 22-joint pose into anny's own pose parameters.

        Parameters
        ----------
        shape : (b, 6) phenotype; pose : (b, 22, 3) axis-angle.
        parameterization : anny pose parameterization (``"local-ref"`` or ``"world"``).

        Returns
        -------
        (b, 104, 4, 4) float64 tensor for ``self.anny(pose_parameters=..., phenotype_kwargs=
        shape, pose_parameterization=parameterization)``; anny's posed skin then equals this
        model's vertices (rotated back into anny's frame).
        """
        # heavy: torch (~1.1 s to import)
        import torch

        out = self.forward(torch.as_tensor(np.asarray(shape), dtype=torch.float64),
                           torch.as_tensor(np.asarray(pose), dtype=torch.float64))
        m = self.anny
        coeffs_shape = torch.as_tensor(np.asarray(shape), dtype=torch.float64).reshape(-1, 6)
        verts, _ = self._anny_rest(coeffs_shape)
        local = m._parse_parameter_kwargs(None, m.local_change_labels, 0.0, "local_changes_kwargs")
        facial = m._parse_parameter_kwargs(None, m.facial_action_labels, 0.0, "facial_actions")
        b = coeffs_shape.shape[0]
        empty = coeffs_shape.new_zeros(b, 0)
        coeffs = m._get_phenotype_blendshape_coefficients(
            coeffs_shape, local.expand(b, -1) if local.shape[-1] else empty,
            facial.expand(b, -1) if facial.shape[-1] else empty)
        rest_poses = m.get_rest_model(coeffs)["rest_bone_poses"]
        R4 = torch.eye(4, dtype=torch.float64)
        R4[:3, :3] = torch.as_tensor(ANNY_TO_SMPL_FRAME)
        A = R4.T @ out.transforms @ R4  # LBS matrices in anny's frame
        bj = torch.as_tensor(self.bone_joint)
        world = A[:, bj] @ rest_poses
        if parameterization == "world":
            return world
        return m.get_pose_parameterization({"rest_bone_poses": rest_poses, "bone_poses": world},
                                           parameterization)
