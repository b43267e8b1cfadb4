"""Fixtures of the bench tests: a tiny dataset built with the real DatasetWriter and the
procedural body model, an edition pinned to it, and ready-made submissions."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

BENCHMARKS = Path(__file__).resolve().parents[2] / "benchmarks"


def benchmark_script(name: str):
    """The module ``benchmarks/<name>.py``, loaded from its file (the scripts are not a
    package)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(name, BENCHMARKS / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


FIXTURE_GENERATOR = {"name": "bench-test-fixture", "version": "1",
                     "params": {"garments": 3, "poses": 3}, "seed": 0}


def tube(radius: float, y0: float, y1: float, nu: int, nv: int) -> tuple[np.ndarray, np.ndarray]:
    """An open cylinder around the y axis: (nu * nv, 3) vertices and faces, outward normals."""
    u = np.linspace(0, 2 * np.pi, nu, endpoint=False)
    v = np.linspace(y0, y1, nv)
    uu, vv = np.meshgrid(u, v)
    V = np.stack([radius * np.cos(uu), vv, radius * np.sin(uu)], -1).reshape(-1, 3)
    F = []
    for j in range(nv - 1):
        for i in range(nu):
            a, b = j * nu + i, j * nu + (i + 1) % nu
            c, d = a + nu, b + nu
            F += [[a, c, b], [b, c, d]]
    return V, np.asarray(F, dtype=np.int64)


def pose_garment(V: np.ndarray, pose: int, seed: int) -> np.ndarray:
    """A smooth, seeded deformation standing in for the garment in pose ``pose``."""
    rng = np.random.default_rng(seed * 10 + pose)
    amp = 0.01 * pose
    phase = rng.uniform(0, 2 * np.pi, 3)
    W = V.copy()
    W[:, 0] += amp * np.sin(3 * V[:, 1] + phase[0])
    W[:, 2] += amp * np.cos(2 * V[:, 1] + phase[1])
    W[:, 1] += 0.5 * amp * np.sin(2 * np.arctan2(V[:, 2], V[:, 0]) + phase[2])
    return W


def build_fixture_dataset(root: Path) -> Path:
    """3 garments (topwear, bottomwear, dress) x 3 poses, all in the test split; garment
    G03 is remeshed in pose P2 (its topology differs there, so ED is undefined)."""
    from dressmeup.body import get_body_model
    from dressmeup.data.writer import DatasetWriter

    model = get_body_model("procedural")
    w = DatasetWriter(root, {"name": "bench-fixture", "version": "1", "licence": "CC0",
                             "body_model": "procedural", "generator": FIXTURE_GENERATOR})
    garments = [("G01", "topwear", "t-shirt", tube(0.17, 1.05, 1.45, 24, 9)),
                ("G02", "bottomwear", "trousers", tube(0.15, 0.55, 0.95, 20, 8)),
                ("G03", "dress", "dress", tube(0.19, 0.7, 1.4, 22, 10))]
    for gi, (gid, cat, gtype, (V, F)) in enumerate(garments):
        for p in range(3):
            params = model.default_params()
            params.pose[16, 2] = -0.4 * p   # left shoulder
            params.pose[17, 2] = 0.4 * p    # right shoulder
            params.transl[:] = [0.0, 0.0, 0.01 * p]
            if gid == "G03" and p == 2:
                Vp, Fp = tube(0.19, 0.7, 1.4, 26, 11)
            else:
                Vp, Fp = V, F
            Vp = pose_garment(Vp, p, gi) + params.transl
            B = model.posed(params).vertices
            scan = (np.vstack([B, Vp]), np.vstack([model.faces, Fp + len(B)]))
            w.add_sample(subject_id="S01", garment_id=gid, pose_id=f"P{p}", category=cat,
                         garment_type=gtype, split="test", garment=(Vp, Fp), body=params,
                         scan=scan)
    w.finalize()
    return root


def write_edition(path: Path, n_samples: int = 2000, **over) -> Path:
    ed = {"schema": "dressmeup-edition/1", "name": "bench-fixture-v1", "version": 1,
          "task": "retarget", "description": "test fixture",
          "dataset": {"kind": "generated", "generator": FIXTURE_GENERATOR["name"],
                      "generator_version": FIXTURE_GENERATOR["version"],
                      "params": FIXTURE_GENERATOR["params"], "seed": 0},
          "split": "test", "metrics": ["p2s", "p2s_bi", "chamfer", "ed", "nc", "ir"],
          "options": {"n_samples": n_samples, "seed": 0}, "primary_metric": "p2s",
          "per_category": ["p2s"]}
    ed.update(over)
    path.write_text(json.dumps(ed, indent=2))
    return path


@pytest.fixture(scope="session")
def bench_data(tmp_path_factory) -> Path:
    """The fixture dataset root (built once per session)."""
    return build_fixture_dataset(tmp_path_factory.mktemp("bench-data") / "data")


@pytest.fixture(scope="session")
def bench_edition(tmp_path_factory) -> Path:
    """Path of an edition JSON pinned to the fixture dataset."""
    return write_edition(tmp_path_factory.mktemp("bench-ed") / "bench-fixture-v1.json")


def gt_predictions(root: Path, edition) -> dict[str, np.ndarray]:
    """Ground truth as predictions: for pairs whose target keeps the source topology, the
    target garment's vertices; otherwise the source vertices moved by the mean offset."""
    from dressmeup.bench.edition import load_edition
    from dressmeup.data import Dataset

    ed = load_edition(edition)
    ds = Dataset(root)
    preds = {}
    for pair in ds.retarget_pairs(ed.split):
        s, t = pair.source.garment(), pair.target.garment()
        if s.vertices.shape == t.vertices.shape and np.array_equal(s.faces, t.faces):
            preds[pair.pair_id] = np.asarray(t.vertices, np.float64)
        else:
            preds[pair.pair_id] = s.vertices + (t.vertices.mean(0) - s.vertices.mean(0))
    return preds


def perturbed_predictions(root: Path, edition, sigma: float = 0.002, seed: int = 7
                          ) -> dict[str, np.ndarray]:
    """Ground-truth predictions plus seeded Gaussian noise (sigma in metres)."""
    rng = np.random.default_rng(seed)
    preds = gt_predictions(root, edition)
    return {k: v + rng.normal(0.0, sigma, v.shape) for k, v in sorted(preds.items())}


def make_submission(folder: Path, preds: dict, edition, method: str) -> Path:
    from dressmeup.bench import write_submission

    return write_submission(folder, preds, edition=edition, method=method,
                            authors="Test Author", url="https://example.org/" + method,
                            hardware="2-core CPU", runtime_per_sample_s=0.5)


@pytest.fixture(scope="session")
def scored(bench_data, bench_edition, tmp_path_factory) -> dict:
    """Submissions and results of GT and GT+noise on the fixture (scored once, serially)."""
    from dressmeup.bench import score_submission

    base = tmp_path_factory.mktemp("bench-scored")
    out = {}
    for name, preds in (("gt", gt_predictions(bench_data, bench_edition)),
                        ("noisy", perturbed_predictions(bench_data, bench_edition))):
        sub = make_submission(base / f"sub-{name}", preds, bench_edition, name.upper())
        res = score_submission(sub, bench_edition, bench_data, base / f"res-{name}",
                               workers=1, show_progress=False)
        out[name] = {"sub": sub, "res": res}
    return out


class ShortcutCheck:
    """The no-shortcut tests' bench: a tiny retargeting edition's parts (built into the test
    cache where the journey and the server tests keep them) and mean P2S (m) of submissions
    scored on its private part."""

    def __init__(self, edition: str, other_data) -> None:
        from dressmeup import runs
        from dressmeup.bench import load_edition
        from dressmeup.bench.tasks.retarget.data import edition_pairs, open_dataset
        from dressmeup.cache import cache_dir

        self.ed = ed = load_edition(edition)
        self.parts = runs.build_parts(ed, cache_dir("e2e") / f"{ed.name}-{ed.hash[:10]}",
                                      allow_other_data=True)
        other_data(ed, self.parts.full)  # the pin or a known machine's data; else it fails
        self.other = runs.data_differs(ed, self.parts.full) is not None
        self.pairs = edition_pairs(ed, open_dataset(str(self.parts.public.resolve())))

    def mean_p2s(self, sub: Path, out: Path) -> float:
        from dressmeup.bench.scoring.score import score_submission

        res = score_submission(sub, self.ed, self.parts.private, out, workers=1,
                               show_progress=False, allow_other_data=self.other)
        assert (res.table["status"] == "ok").all()
        return float(res.table["p2s"].mean())

    def references(self, tmp_path: Path, methods=("rigid", "skinning", "transfer"),
                   extra: dict | None = None) -> dict[str, float]:
        """Mean P2S of the reference baselines run on the public part (and of ``extra``:
        name -> predictions)."""
        from dressmeup import runs
        from dressmeup.bench import write_submission

        subs = runs.run_baselines(self.ed, self.parts.public, tmp_path / "ref",
                                  methods=list(methods))
        assert set(subs) == set(methods)
        for name, preds in (extra or {}).items():
            subs[name] = write_submission(tmp_path / "ref" / name, preds, edition=self.ed,
                                          method=name)
        return {n: self.mean_p2s(s, tmp_path / f"res-ref-{n}") for n, s in subs.items()}

    def shortcuts(self, tmp_path: Path, ops: dict, public) -> dict[str, float]:
        """Mean P2S of each shortcut ``ops[name](public(public_root, pair)) -> (n, 3)``."""
        from dressmeup.bench import write_submission

        out = {}
        for name, op in ops.items():
            preds = {p.pair_id: op(public(self.parts.public, p)) for p in self.pairs}
            sub = write_submission(tmp_path / f"sub-{name}", preds, edition=self.ed,
                                   method=name)
            out[name] = self.mean_p2s(sub, tmp_path / f"res-{name}")
        return out


@pytest.fixture(scope="session")
def shortcut_check(other_data):
    """``f(edition) -> ShortcutCheck``, one per edition and run."""
    made: dict[str, ShortcutCheck] = {}

    def get(edition: str) -> ShortcutCheck:
        if edition not in made:
            made[edition] = ShortcutCheck(edition, other_data)
        return made[edition]

    return get
