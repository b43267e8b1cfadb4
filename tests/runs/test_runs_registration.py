"""The registration baseline runner (``runs.run_registration_baseline``, the path of
``benchmarks/run_baselines.py --editions synth-registration-v3``): one body file per test scan,
scoreable by the registration task. A stand-in registrar keeps it fast; the real fit is
measured by benchmarks/perf/registration.py and the reference tables."""

from __future__ import annotations

import numpy as np
import pytest

from dressmeup import runs
from dressmeup.body import BodyParams
from dressmeup.body.registration import RegistrationResult, add_registrar
from dressmeup.errors import InputError


class _RestPose:
    """Stand-in registrar: the model's default body moved to the scan's centroid."""

    def fit(self, scan, model, init=None, keypoints=None):
        p = model.default_params()
        V = np.asarray(scan[0], float)
        return RegistrationResult(params=BodyParams(model=model.name, shape=p.shape, pose=p.pose,
                                                    transl=V.mean(0)), seconds=0.0)


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    from dressmeup.data.synth import generate_dataset

    add_registrar("test-rest-pose", lambda **_: _RestPose())
    # generator 3.0.0 (its bytes do not depend on the CPU), scans without the covered skin as
    # in synth-registration-v3; the runner does not depend on the pose set
    return generate_dataset(tmp_path_factory.mktemp("reg") / "d", version="3.0.0", subjects=2,
                            poses=1, garments_per_split=(0, 0, 1), categories=["topwear"],
                            body_model="procedural", edge_length=0.05, scan_body="uncovered")


def test_runner_writes_a_scoreable_submission(data, tmp_path):
    from dressmeup.bench.edition_create import create_edition
    from dressmeup.bench.scoring.score import score_submission

    # the edition's protocol on this small dataset (an edition pinned by its manifest)
    ed = create_edition(data, "registration", "small-registration")
    sub = runs.run_registration_baseline("register", ed, data, tmp_path / "sub",
                                         registrar="test-rest-pose")
    files = sorted(p.name for p in sub.glob("*.npz"))
    assert files == ["S01-G01-P1.npz", "S02-G01-P1.npz"]
    assert BodyParams.load(sub / files[0]).model == "procedural"
    res = score_submission(sub, ed, data, tmp_path / "res")
    table = res.table
    assert len(table) == 2 and np.isfinite(table["v2v"]).all() and (table["v2v"] > 0).all()


def test_unknown_registration_baseline(data, tmp_path):
    with pytest.raises(InputError, match="known"):
        runs.run_registration_baseline("icp", "synth-registration-v3", data, tmp_path / "sub")
    assert runs.registration_methods() == ["register"]
