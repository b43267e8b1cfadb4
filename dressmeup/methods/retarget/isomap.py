"""``isomap``: coarse placement of a garment by Isomap correspondences (thesis 4.3.1).

The pieces live by idea: :mod:`~dressmeup.methods.retarget.embedding` (template geodesics and
the cached embedding), :mod:`~dressmeup.methods.retarget.mds` (MDS),
:mod:`~dressmeup.methods.retarget.correspondence` (eq. 4.1, eq. 4.4) and
:mod:`~dressmeup.methods.retarget.prepared` (the per-garment precomputation). This module holds
the method and re-exports the old names (``from dressmeup.methods.retarget.isomap import
place`` keeps working).
"""

from __future__ import annotations

import time

import numpy as np

from dressmeup.geometry.laplacian import uniform_laplacian
from dressmeup.methods.retarget.base import RetargetMethod, body_context, check_garment
from dressmeup.methods.retarget.correspondence import (
    CoarseResult,
    coarse_retarget,
    inverse_distance_weights,
    knn_embedding,
)
from dressmeup.methods.retarget.embedding import (
    TemplateEmbedding,
    embedding_for,
)
from dressmeup.methods.retarget.prepared import prepare_garment

__all__ = ["IsomapRetarget", "IsomapOffset"]


class IsomapRetarget(RetargetMethod):
    """``isomap``: coarse placement by Isomap correspondences through the body template.

    Parameters
    ----------
    dim : int
        Embedding dimension (thesis: 128).
    k_extrapolate : int
        Neighbours of eq. 4.1 (thesis: 32).
    k_place : int
        Neighbours of eq. 4.4 (thesis: 32; the authors' demo: 3).
    embedding_method : {"auto", "full", "landmark"}
    n_landmarks : int
        Landmarks of landmark MDS.
    offset : float
        Metres to push each coarse point out along the interpolated target normal (thesis: 0;
        demo: 0.02).
    smooth_iterations : int
        Uniform 1-ring smoothing steps of the coarse garment (thesis: 0; demo: 5).
    correspondence_noise : float
        Standard deviation (metres) of Gaussian noise added to every coarse point, for the
        noise ablation of thesis Table 4.2 (default 0: none).
    carry_offset : bool
        The loose-garment variant (not in the thesis; ``isomap-offset``): push each coarse
        point along the interpolated target normal by the garment vertex's signed offset from
        its own correspondence on the source body (:class:`~dressmeup.methods.retarget.prepared.PreparedGarment`),
        so that a dress or skirt keeps its distance from the body instead of collapsing onto
        the skin (eq. 4.4 is a convex combination of skin vertices).
    precompute : bool
        Use the per-garment preparation (eq. 4.1 and the k-NN of eq. 4.4 once per garment and
        source body, cached by content hash; each target is then a gather). ``False`` runs the
        general path (both k-NN searches per call), which is what a target of another topology
        (a raw scan) needs; on template-topology targets both give the same result.
    seed : int
        Landmark choice and the noise.
    """

    name = "isomap"

    def __init__(self, dim: int = 128, k_extrapolate: int = 32, k_place: int = 32,
                 embedding_method: str = "auto", n_landmarks: int = 2000, offset: float = 0.0,
                 smooth_iterations: int = 0, correspondence_noise: float = 0.0, carry_offset: bool = False,
                 precompute: bool = True, seed: int = 0) -> None:
        self.carry_offset = carry_offset
        self.precompute = precompute
        self.dim = dim
        self.k_extrapolate = k_extrapolate
        self.k_place = k_place
        self.embedding_method = embedding_method
        self.n_landmarks = n_landmarks
        self.offset = offset
        self.smooth_iterations = smooth_iterations
        self.correspondence_noise = correspondence_noise
        self.seed = seed

    def embedding(self, body_model) -> TemplateEmbedding:
        """The (cached) template embedding these hyperparameters use."""
        return embedding_for(body_model, dim=self.dim, method=self.embedding_method,
                             n_landmarks=self.n_landmarks, seed=self.seed)

    def prepared(self, garment_V, garment_F, source_context, embedding: TemplateEmbedding):
        """The per-garment preparation (cached by content hash; see :mod:`~dressmeup.methods.retarget.prepared`).

        Parameters
        ----------
        garment_V : (n, 3) float array; garment_F : (m, 3) int array.
        source_context : BodyContext of the source body; embedding : TemplateEmbedding.

        Returns
        -------
        PreparedGarment
        """

        return prepare_garment(garment_V, garment_F, source_context.skin_vertices, source_context.skin_normals,
                               embedding.embedding, self.k_extrapolate, self.k_place)

    def coarse(self, garment_V, garment_F, source, target, body_model):
        """Coarse placement with everything the refinement needs.

        Returns
        -------
        (CoarseResult, source BodyContext, target BodyContext, TemplateEmbedding)
        """

        V, F = check_garment(garment_V, garment_F)
        emb = self.embedding(body_model)
        s, t = body_context(body_model, source), body_context(body_model, target)
        if not np.array_equal(emb.vertex_ids, s.skin_ids):
            raise ValueError("body_model: the embedding's skin does not match the model's skin component")
        prep = None
        if self.precompute or self.carry_offset:
            prep = self.prepared(V, F, s, emb)
        if self.precompute:
            t0 = time.perf_counter()
            x = prep.coarse(t.skin_vertices)
            res = CoarseResult(positions=x, garment_embedding=prep.phi, seconds_extrapolate=prep.seconds,
                               seconds_place=time.perf_counter() - t0)
        else:
            res = coarse_retarget(V, s.skin_vertices, t.skin_vertices, emb.embedding,
                                  self.k_extrapolate, self.k_place)
            x = res.positions
        if self.offset or self.carry_offset:
            if prep is not None:
                n = prep.normals(t.skin_normals())
            else:
                dist, idx = knn_embedding(res.garment_embedding, emb.embedding, k=self.k_place)
                w = inverse_distance_weights(dist)
                n = np.einsum("nk,nkc->nc", w, t.skin_normals()[idx])
                n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
            if self.offset:
                x = x + float(self.offset) * n
            if self.carry_offset:
                x = x + prep.source_offset[:, None] * n
        if self.smooth_iterations:
            L = uniform_laplacian(F, V.shape[0])
            for _ in range(int(self.smooth_iterations)):
                x = x - L @ x
        if self.correspondence_noise:
            rng = np.random.default_rng(self.seed)
            x = x + rng.normal(0.0, float(self.correspondence_noise), size=x.shape)
        res.positions = x
        return res, s, t, emb

    def retarget(self, garment_V, garment_F, source, target, body_model) -> np.ndarray:
        """See :mod:`dressmeup.methods.retarget.base`; returns (n, 3) float64."""
        return self.coarse(garment_V, garment_F, source, target, body_model)[0].positions


class IsomapOffset(IsomapRetarget):
    """``isomap-offset``: ``isomap`` with ``carry_offset=True`` (the loose-garment variant).

    Each coarse point is pushed along the target normal by the garment vertex's signed
    distance from its correspondence on the source body. Not in the thesis (which states loose
    garments as a limitation, 4.6.4); the authors' demo pushes every point out by a constant
    2 cm instead (``offset=0.02``). Same hyperparameters as :class:`IsomapRetarget`.
    """

    name = "isomap-offset"

    def __init__(self, dim: int = 128, k_extrapolate: int = 32, k_place: int = 32,
                 embedding_method: str = "auto", n_landmarks: int = 2000, offset: float = 0.0,
                 smooth_iterations: int = 0, correspondence_noise: float = 0.0, carry_offset: bool = True,
                 precompute: bool = True, seed: int = 0) -> None:
        super().__init__(dim=dim, k_extrapolate=k_extrapolate, k_place=k_place, embedding_method=embedding_method,
                         n_landmarks=n_landmarks, offset=offset, smooth_iterations=smooth_iterations,
                         correspondence_noise=correspondence_noise, carry_offset=carry_offset,
                         precompute=precompute, seed=seed)
