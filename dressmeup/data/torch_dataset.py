"""A ``torch.utils.data.Dataset`` over a :class:`dressmeup.data.Dataset` (imports torch)."""

from __future__ import annotations

from typing import Any

import torch
from torch.utils.data import Dataset as _TorchBase


class TorchDataset(_TorchBase):
    """A map-style torch dataset over a :class:`dressmeup.data.Dataset` view.

    Items are dicts: ``sample_id``, ``garment_id``, ``pose_id``, ``category``,
    ``vertices (n, 3) float32 tensor``, ``faces (m, 3) int64 tensor`` and, with
    ``load_body``, ``body_shape (s,)``, ``body_pose (j, 3)``, ``body_transl (3,)``,
    ``body_scale ()`` tensors; with ``load_scan``, ``scan_vertices`` and ``scan_faces``.
    Garments differ in vertex count: batch with ``DataLoader(ds, batch_size=8,
    collate_fn=collate)`` (padding + masks, see :func:`collate`).
    """

    def __init__(self, dataset: Any, load_body: bool = True, load_scan: bool = False) -> None:
        self.dataset = dataset
        self.load_body = load_body
        self.load_scan = load_scan

    def __len__(self) -> int:
        return len(self.dataset)

    def __getitem__(self, index: int) -> dict[str, Any]:
        return sample_item(self.dataset[index], self.load_body, self.load_scan)


#: Per-item tensors whose first dimension varies between samples (padded by :func:`collate`).
VARIABLE = ("vertices", "faces", "scan_vertices", "scan_faces")


def collate(batch: list[Any]) -> dict[str, Any]:
    """Batch items of :class:`TorchDataset` (or :class:`~dressmeup.data.Sample` objects,
    e.g. from ``DataLoader(dressmeup.data.Dataset(root), collate_fn=collate)``).

    Returns
    -------
    dict with
    - ids and categories as lists of ``str`` (``sample_id``, ``garment_id``, ...);
    - ``vertices (B, N, 3) float32`` padded with zeros to the largest ``N`` of the batch,
      ``vertices_mask (B, N) bool`` (True on real vertices) and ``vertices_count (B,) int64``;
      the same for ``faces (B, M, 3) int64`` (padding rows are ``-1``) and, when loaded,
      ``scan_vertices`` / ``scan_faces``;
    - body parameters stacked: ``body_shape (B, s)``, ``body_pose (B, j, 3)``,
      ``body_transl (B, 3)``, ``body_scale (B,)`` (only when every item has a body).
    """
    items = [b if isinstance(b, dict) else sample_item(b) for b in batch]
    if not items:
        return {}
    out: dict[str, Any] = {}
    for key in items[0]:
        values = [it.get(key) for it in items]
        if any(v is None for v in values):
            continue
        if not isinstance(values[0], torch.Tensor):
            out[key] = list(values)
        elif key in VARIABLE:
            n = max(int(v.shape[0]) for v in values)
            fill = -1 if not values[0].is_floating_point() else 0
            padded = values[0].new_full((len(values), n, *values[0].shape[1:]), fill)
            mask = torch.zeros((len(values), n), dtype=torch.bool)
            for i, v in enumerate(values):
                padded[i, : v.shape[0]] = v
                mask[i, : v.shape[0]] = True
            out[key] = padded
            out[f"{key}_mask"] = mask
            out[f"{key}_count"] = torch.tensor([int(v.shape[0]) for v in values])
        else:
            out[key] = torch.stack(values)
    return out


def sample_item(s: Any, load_body: bool = True, load_scan: bool = False) -> dict[str, Any]:
    """The tensors of one :class:`~dressmeup.data.Sample` (see :class:`TorchDataset`)."""
    g = s.garment()
    item: dict[str, Any] = {k: s.row[k] for k in ("sample_id", "garment_id", "pose_id",
                                                    "category")}
    item["vertices"] = torch.as_tensor(g.vertices, dtype=torch.float32)
    item["faces"] = torch.as_tensor(g.faces, dtype=torch.int64)
    if load_body:
        b = s.body()
        if b is not None:
            item["body_shape"] = torch.as_tensor(b.shape, dtype=torch.float32)
            item["body_pose"] = torch.as_tensor(b.pose, dtype=torch.float32)
            item["body_transl"] = torch.as_tensor(b.transl, dtype=torch.float32)
            item["body_scale"] = torch.tensor(float(b.scale))
    if load_scan:
        sc = s.scan()
        if sc is not None:
            item["scan_vertices"] = torch.as_tensor(sc[0], dtype=torch.float32)
            item["scan_faces"] = torch.as_tensor(sc[1], dtype=torch.int64)
    return item
