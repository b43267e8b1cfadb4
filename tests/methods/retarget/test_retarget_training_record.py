"""The training record of ``train_from_dataset`` (``dressmeup baseline train-retarget``)
says the passes over the training pairs and the machine."""

import os

import pytest
import torch

from dressmeup.bench.scoring.provenance import cpu_model


def test_training_record_says_passes_and_machine(tiny_retarget_data, tmp_path):
    from dressmeup.methods.retarget.train_dataset import train_from_dataset

    info = train_from_dataset(tiny_retarget_data, tmp_path / "w.pt", split="test", val_split=None,
                              steps=3, max_triplets=4, params=dict(dim=16, embedding_method="landmark",
                              n_landmarks=60, width=16, depth=2, code_dim=8, pointnet_hidden=8,
                              n_points=64))
    assert info["train_pairs"] == 4 and info["steps_done"] == 3
    assert info["passes"] == pytest.approx(3 / 4)
    assert info["machine"] == {"cpu": cpu_model(), "cores": os.cpu_count(),
                               "torch": torch.__version__, "threads": torch.get_num_threads()}
    saved = torch.load(tmp_path / "w.pt", map_location="cpu", weights_only=False)["training"]
    assert saved["passes"] == info["passes"] and saved["machine"] == info["machine"]
