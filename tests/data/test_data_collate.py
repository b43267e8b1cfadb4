"""Batching garments of different vertex counts."""

from __future__ import annotations

import numpy as np
import pytest

torch = pytest.importorskip("torch")


class _Sample:
    def __init__(self, i, n):
        from dressmeup.data.dataset import GarmentMesh

        rng = np.random.default_rng(i)
        self.row = {"sample_id": f"S{i}", "garment_id": f"G{i}", "pose_id": "P1",
                    "category": "dress"}
        self._g = GarmentMesh(rng.random((n, 3)), np.array([[0, 1, 2]] * (n - 2)), None,
                              None, None)

    def garment(self):
        return self._g

    def body(self):
        from dressmeup.body import BodyParams

        return BodyParams(model="procedural", shape=np.zeros(4), pose=np.zeros((22, 3)))

    def scan(self):
        return None


def test_dataloader_over_samples_pads_and_masks():
    from torch.utils.data import DataLoader

    from dressmeup.data.torch_dataset import collate

    samples = [_Sample(0, 5), _Sample(1, 9), _Sample(2, 7)]
    batch = next(iter(DataLoader(samples, batch_size=3, collate_fn=collate)))
    assert batch["sample_id"] == ["S0", "S1", "S2"]
    assert batch["vertices"].shape == (3, 9, 3) and batch["vertices"].dtype == torch.float32
    assert batch["vertices_count"].tolist() == [5, 9, 7]
    assert batch["vertices_mask"].sum(1).tolist() == [5, 9, 7]
    assert torch.allclose(batch["vertices"][0, :5],
                          torch.as_tensor(samples[0].garment().vertices, dtype=torch.float32))
    assert (batch["vertices"][0, 5:] == 0).all() and (batch["faces"][0, 3:] == -1).all()
    assert batch["body_pose"].shape == (3, 22, 3)
