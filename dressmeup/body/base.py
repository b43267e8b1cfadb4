"""The body-model protocol and a shared LBS implementation.

Every body model exposes a fixed mesh topology, a skeleton and skinning weights, and a
batched, differentiable ``forward`` in torch::

    out = model.forward(shape, pose, transl=None, scale=None)
    out.vertices   # (b, n, 3) = scale * posed(shape, pose) + transl
    out.joints     # (b, j, 3) posed joints, same scale/transl
    out.transforms # (b, j, 4, 4) LBS matrices, shaped rest pose -> posed (before scale/transl)
    out.rest_vertices  # (b, n, 3) shaped, unposed (before scale/transl)

Convention (docs/spec.md section 2): ``vertices = scale * model(shape, pose) + transl``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

import numpy as np

from dressmeup.body.lbs import axis_angle_to_matrix, forward_kinematics, skin_points
from dressmeup.body.params import BodyParams
from dressmeup.errors import InputError

if TYPE_CHECKING:  # pragma: no cover
    import torch


@dataclass
class BodyOutput:
    """Result of a body-model forward pass.

    Torch tensors from :meth:`BodyModel.forward` (batched), numpy arrays without the batch
    axis from :meth:`BodyModel.posed`.

    Attributes
    ----------
    vertices : (b, n, 3) posed vertices, ``scale * v + transl``.
    joints : (b, j, 3) posed joint positions, ``scale * J + transl``.
    transforms : (b, j, 4, 4) LBS matrices mapping the shaped rest pose to the posed body
        before scale and translation.
    rest_vertices : (b, n, 3) shaped vertices in the rest pose (no scale/translation).
    rest_joints : (b, j, 3) shaped joints in the rest pose (no scale/translation).
    """

    vertices: Any
    joints: Any
    transforms: Any
    rest_vertices: Any
    rest_joints: Any = None


@runtime_checkable
class BodyModel(Protocol):
    """What every body model provides (see module docstring)."""

    name: str
    faces: np.ndarray  # (m, 3) int64
    joint_names: tuple[str, ...]
    joint_parents: np.ndarray  # (j,) int64, -1 for the root
    skinning_weights: np.ndarray  # (n, j) float64, rows sum to 1
    template_vertices: np.ndarray  # (n, 3) float64, average shape, rest pose
    shape_dim: int

    @property
    def n_vertices(self) -> int: ...

    def forward(self, shape, pose, transl=None, scale=None) -> BodyOutput: ...

    def posed(self, params: BodyParams) -> BodyOutput: ...

    def skin(self) -> tuple[np.ndarray, np.ndarray]: ...


class LBSBodyModel:
    """Base class: shape-dependent rest mesh and joints, then linear blend skinning.

    Subclasses set ``name``, ``faces``, ``joint_names``, ``joint_parents``,
    ``skinning_weights``, ``template_vertices``, ``shape_dim``, ``default_shape`` and
    implement :meth:`rest` (and optionally :meth:`pose_offsets` for pose correctives).
    """

    name: str = ""
    gender: str = "neutral"
    faces: np.ndarray
    joint_names: tuple[str, ...]
    joint_parents: np.ndarray
    skinning_weights: np.ndarray
    template_vertices: np.ndarray
    shape_dim: int
    default_shape: np.ndarray

    # ----------------------------------------------------------- properties
    @property
    def n_vertices(self) -> int:
        """Number of vertices ``n``."""
        return int(self.template_vertices.shape[0])

    @property
    def n_joints(self) -> int:
        """Number of joints ``j``."""
        return len(self.joint_names)

    def __repr__(self) -> str:
        return (f"{type(self).__name__}(name={self.name!r}, n_vertices={self.n_vertices}, "
                f"n_joints={self.n_joints}, shape_dim={self.shape_dim})")

    def skin(self) -> tuple[np.ndarray, np.ndarray]:
        """The body surface: the largest connected component of the mesh (by vertex count).

        Eyes, teeth or other separate parts are left out; geodesics, closest-point queries on
        the body and the benchmark's penetration tests use this surface. ``anny`` and the
        procedural body are one component already (anny drops its other parts when it is
        built), so their skin is the whole mesh; an SMPL-family mesh is one component too.

        Returns
        -------
        vertex_ids : (s,) int64
            Increasing indices of the skin's vertices into this model's vertices.
        faces : (f, 3) int64
            The skin's faces (in model face order) re-indexed into ``vertex_ids``.

        Computed once and kept on the instance: the arrays are shared, do not modify them.
        """
        cached = self.__dict__.get("_skin")
        if cached is None:
            # heavy: scipy.sparse
            from dressmeup.geometry.topology import largest_component

            cached = self.__dict__["_skin"] = largest_component(self.faces, self.n_vertices,
                                                                by="vertices")
        return cached

    # --------------------------------------------------------------- hooks
    def rest(self, shape: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Return shaped rest vertices (b, n, 3) and rest joints (b, j, 3) for shape (b, s)."""
        raise NotImplementedError

    def rest_subset(self, shape: torch.Tensor, vertex_ids: torch.Tensor
                    ) -> tuple[torch.Tensor, torch.Tensor]:
        """Shaped rest vertices of ``vertex_ids`` (k,) only, (b, k, 3), and the rest joints
        (b, j, 3): the same values as ``rest(shape)`` selected. Models whose shape is a
        per-vertex blend may compute only those rows (anny does, when the shape needs a
        gradient: registration's shape steps)."""
        V, J = self.rest(shape)
        return V[:, vertex_ids], J

    def rest_extent(self, shape: torch.Tensor, axis: int = 1) -> torch.Tensor:
        """(b,) extent (max - min, m) of the shaped rest vertices along ``axis`` for shape
        (b, s): the same values as from ``rest(shape)`` (models may compute only what the
        extent needs; anny computes one coordinate)."""
        V, _ = self.rest(shape)
        x = V[..., axis]
        return x.max(1).values - x.min(1).values

    def pose_offsets(self, rotations: torch.Tensor) -> torch.Tensor | None:
        """Optional pose-dependent corrective offsets (b, n, 3) added before skinning."""
        return None

    def _buffer(self, name: str, dtype, device) -> torch.Tensor:
        """Return numpy attribute ``name`` as a tensor (cached per dtype/device)."""
        # heavy: torch (~1.1 s to import)
        import torch

        cache = self.__dict__.setdefault("_tensor_cache", {})
        key = (name, dtype, str(device))
        if key not in cache:
            cache[key] = torch.as_tensor(np.asarray(getattr(self, name)), dtype=dtype, device=device)
        return cache[key]

    # -------------------------------------------------------------- forward
    def default_params(self, batch: int | None = None) -> BodyParams:
        """Return average-shape, zero-pose parameters for this model."""
        return BodyParams(model=self.name, gender=self.gender, shape=self.default_shape.copy(),
                          pose=np.zeros((self.n_joints, 3)))

    def _prepare(self, shape, pose, transl, scale):
        # heavy: torch (~1.1 s to import)
        import torch

        ref = next((x for x in (pose, shape, transl, scale) if isinstance(x, torch.Tensor)), None)
        dtype = ref.dtype if ref is not None and ref.is_floating_point() else torch.float32
        device = ref.device if ref is not None else torch.device("cpu")

        def as_t(x, name):
            if isinstance(x, torch.Tensor):
                return x.to(dtype=dtype, device=device)
            try:
                return torch.as_tensor(np.asarray(x, dtype=np.float64), dtype=dtype, device=device)
            except (TypeError, ValueError) as exc:
                raise InputError(f"{name}: expected numbers, got {type(x).__name__}") from exc

        pose_t = as_t(pose, "pose")
        if pose_t.dim() == 2:
            pose_t = pose_t[None]
        j = self.n_joints
        if pose_t.dim() != 3 or pose_t.shape[1:] != (j, 3):
            raise InputError(f"pose: expected shape (b, {j}, 3) for model {self.name!r}, "
                             f"got {tuple(pose_t.shape)}")
        b = pose_t.shape[0]
        shape_t = as_t(shape, "shape")
        if shape_t.dim() == 1:
            shape_t = shape_t[None]
        if shape_t.dim() != 2 or shape_t.shape[1] > self.shape_dim:
            raise InputError(f"shape: expected shape (b, {self.shape_dim}) for model "
                             f"{self.name!r}, got {tuple(shape_t.shape)}")
        if shape_t.shape[1] < self.shape_dim:  # pad with the model's average values
            pad = self._buffer("default_shape", dtype, device)[shape_t.shape[1]:]
            shape_t = torch.cat([shape_t, pad.expand(shape_t.shape[0], -1)], dim=1)
        if shape_t.shape[0] == 1 and b > 1:
            shape_t = shape_t.expand(b, -1)
        if shape_t.shape[0] != b:
            raise InputError(f"shape: batch {shape_t.shape[0]} does not match pose batch {b}")
        if transl is None:
            transl_t = torch.zeros(b, 3, dtype=dtype, device=device)
        else:
            transl_t = as_t(transl, "transl").reshape(-1, 3)
            if transl_t.shape[0] == 1 and b > 1:
                transl_t = transl_t.expand(b, 3)
            if transl_t.shape[0] != b:
                raise InputError(f"transl: expected shape ({b}, 3), got {tuple(transl_t.shape)}")
        if scale is None:
            scale_t = torch.ones(b, dtype=dtype, device=device)
        else:
            scale_t = as_t(scale, "scale").reshape(-1)
            if scale_t.shape[0] == 1 and b > 1:
                scale_t = scale_t.expand(b)
            if scale_t.shape[0] != b:
                raise InputError(f"scale: expected shape ({b},), got {tuple(scale_t.shape)}")
        return shape_t, pose_t, transl_t, scale_t

    def forward(self, shape, pose, transl=None, scale=None, vertex_ids=None) -> BodyOutput:
        """Pose and shape a batch of bodies (differentiable in torch).

        Parameters
        ----------
        shape : (b, s) or (s,) tensor/array; fewer than ``shape_dim`` values are padded
            with the model's average values.
        pose : (b, j, 3) or (j, 3) axis-angle per joint, relative to the parent.
        transl : (b, 3) translation, default zeros.
        scale : (b,) uniform scale, default ones.
        vertex_ids : optional (k,) vertex indices: shape and skin only those vertices
            (``vertices`` and ``rest_vertices`` are then (b, k, 3)). Registration uses it.

        Returns
        -------
        BodyOutput of torch tensors (dtype of the first tensor input, else float32).
        """

        shape_t, pose_t, transl_t, scale_t = self._prepare(shape, pose, transl, scale)
        W = self._buffer("skinning_weights", pose_t.dtype, pose_t.device)
        R = axis_angle_to_matrix(pose_t)
        offsets = self.pose_offsets(R)
        if vertex_ids is None:
            rest_v, rest_j = self.rest(shape_t)
        else:
            # heavy: torch (~1.1 s to import)
            import torch

            ids = torch.as_tensor(vertex_ids, dtype=torch.long, device=pose_t.device)
            rest_v, rest_j = self.rest_subset(shape_t, ids)
            W = W[ids]
            offsets = None if offsets is None else offsets[:, ids]
        skinned_in = rest_v if offsets is None else rest_v + offsets
        joints, A = forward_kinematics(R, rest_j, self.joint_parents)
        verts = skin_points(skinned_in, W, A)
        s = scale_t[:, None, None]
        t = transl_t[:, None, :]
        return BodyOutput(vertices=s * verts + t, joints=s * joints + t, transforms=A,
                          rest_vertices=rest_v, rest_joints=rest_j)

    __call__ = forward

    def posed(self, params: BodyParams) -> BodyOutput:
        """Numpy convenience: pose one body from :class:`BodyParams`.

        Returns
        -------
        BodyOutput of float64 numpy arrays without the batch axis: ``vertices (n, 3)``,
        ``joints (j, 3)``, ``transforms (j, 4, 4)``, ``rest_vertices (n, 3)``,
        ``rest_joints (j, 3)``.
        """
        # heavy: torch (~1.1 s to import)
        import torch

        if not isinstance(params, BodyParams):
            raise InputError(f"params: expected BodyParams, got {type(params).__name__}")
        params.check_model(self)
        with torch.no_grad():
            out = self.forward(
                torch.as_tensor(params.shape, dtype=torch.float64)[None],
                torch.as_tensor(params.pose, dtype=torch.float64)[None],
                torch.as_tensor(params.transl, dtype=torch.float64)[None],
                torch.tensor([params.scale], dtype=torch.float64),
            )
        return BodyOutput(*(None if x is None else x[0].detach().cpu().numpy().astype(np.float64)
                            for x in (out.vertices, out.joints, out.transforms,
                                      out.rest_vertices, out.rest_joints)))
