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
    Garments differ in vertex count, so batch with ``batch_size=1`` or a custom collate.
    """

    def __init__(self, dataset: Any, load_body: bool = True, load_scan: bool = False) -> None:
        self.dataset = dataset
        self.load_body = load_body
        self.load_scan = load_scan

    def __len__(self) -> int:
        return len(self.dataset)

    def __getitem__(self, index: int) -> dict[str, Any]:
        s = self.dataset[index]
        g = s.garment()
        item: dict[str, Any] = {k: s.row[k] for k in ("sample_id", "garment_id", "pose_id",
                                                        "category")}
        item["vertices"] = torch.as_tensor(g.vertices, dtype=torch.float32)
        item["faces"] = torch.as_tensor(g.faces, dtype=torch.int64)
        if self.load_body:
            b = s.body()
            if b is not None:
                item["body_shape"] = torch.as_tensor(b.shape, dtype=torch.float32)
                item["body_pose"] = torch.as_tensor(b.pose, dtype=torch.float32)
                item["body_transl"] = torch.as_tensor(b.transl, dtype=torch.float32)
                item["body_scale"] = torch.tensor(float(b.scale))
        if self.load_scan:
            sc = s.scan()
            if sc is not None:
                item["scan_vertices"] = torch.as_tensor(sc[0], dtype=torch.float32)
                item["scan_faces"] = torch.as_tensor(sc[1], dtype=torch.int64)
        return item
