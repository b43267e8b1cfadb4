"""Property-based fuzzing of the readers users hand files to: whatever the bytes, a reader
returns a valid result or raises InputError — never another exception, never a hang, never
more than :data:`MEMORY_LIMIT` of memory for an input of a few kilobytes (a bomb that got
past the limits of dressmeup.limits). Derandomised (the same examples on every run) and
bounded in examples and size: meshes, .npz, .npy, JSON, pickles, Parquet tables, images."""

from __future__ import annotations

import contextlib
import json
import pickle
import tempfile
import tracemalloc
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from dressmeup.errors import InputError

FUZZ = settings(max_examples=60, derandomize=True, deadline=None, database=None,
                suppress_health_check=[HealthCheck.too_slow])
#: Most memory one reader may take on a fuzzed input (Python and numpy allocations, traced;
#: Arrow's pool, counted): the inputs are kilobytes, so more means a bomb got through.
MEMORY_LIMIT = 256 << 20


@contextlib.contextmanager
def bounded_memory():
    """Fail when the block allocates more than :data:`MEMORY_LIMIT` at its peak."""
    import pyarrow as pa

    arrow0 = pa.total_allocated_bytes()
    tracemalloc.start()
    tracemalloc.reset_peak()
    try:
        yield
    finally:
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
    assert peak < MEMORY_LIMIT, f"peak {peak / 2**20:.0f} MiB"
    assert pa.total_allocated_bytes() - arrow0 < MEMORY_LIMIT

_TMP = Path(tempfile.mkdtemp(prefix="dressmeup-fuzz-"))


def _seed_files() -> dict[str, bytes]:
    from dressmeup.io.mesh import save_mesh

    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    F = np.array([[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]])
    out = {}
    save_mesh(_TMP / "seed.ply", V, F, uv=np.random.default_rng(0).random((12, 2)),
              uv_faces=np.arange(12).reshape(4, 3))
    save_mesh(_TMP / "seed.obj", V, F)
    np.savez(_TMP / "seed.npz", vertices=V, faces=F)
    np.save(_TMP / "seed.npy", V)
    for name in ("seed.ply", "seed.obj", "seed.npz", "seed.npy"):
        out[name[-3:]] = (_TMP / name).read_bytes()
    out["pkl"] = pickle.dumps({"betas": np.zeros((1, 10)), "global_orient": np.zeros((1, 3)),
                               "body_pose": np.zeros((1, 63)), "frames": ["00011", "00012"],
                               "nested": [{"a": (1, 2.0, None)}]}, protocol=2)
    out["pkl4"] = pickle.dumps({"v": np.arange(12.0).reshape(4, 3), "s": {1, 2}}, protocol=4)
    import pyarrow as pa
    import pyarrow.parquet as pq

    pq.write_table(pa.table({"sample_id": ["a", "b", "c"], "n": [1, 2, 3],
                             "x": [0.5, None, 2.0]}), _TMP / "seed.parquet")
    out["parquet"] = (_TMP / "seed.parquet").read_bytes()
    from PIL import Image

    Image.fromarray(np.arange(48, dtype=np.uint8).reshape(4, 4, 3)).save(_TMP / "seed.png")
    out["png"] = (_TMP / "seed.png").read_bytes()
    out["ascii.ply"] = (b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                        b"property float y\nproperty float z\nelement face 1\n"
                        b"property list uchar int vertex_indices\nend_header\n"
                        b"0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")
    return out


SEEDS = _seed_files()


@st.composite
def mutated(draw, seed: bytes) -> bytes:
    """A seed file damaged by truncation, byte flips, insertions, or replaced wholesale."""
    kind = draw(st.sampled_from(["truncate", "flip", "insert", "random", "splice"]))
    if kind == "random":
        return draw(st.binary(max_size=400))
    data = bytearray(seed)
    if kind == "truncate":
        return bytes(data[: draw(st.integers(0, len(data)))])
    if kind == "flip":
        for _ in range(draw(st.integers(1, 8))):
            i = draw(st.integers(0, len(data) - 1))
            data[i] = draw(st.integers(0, 255))
        return bytes(data)
    i = draw(st.integers(0, len(data)))
    if kind == "insert":
        return bytes(data[:i] + draw(st.binary(min_size=1, max_size=64)) + data[i:])
    j = draw(st.integers(i, len(data)))
    return bytes(data[:i] + data[j:] + data[i:j])  # move a chunk to the end


def mutated_seed(kind: str):
    """``mutated`` of the seed file ``kind``."""
    return mutated(SEEDS[kind])


def _write(name: str, data: bytes) -> Path:
    path = _TMP / name
    path.write_bytes(data)
    return path


@FUZZ
@given(st.sampled_from(["ply", "ascii.ply", "obj"]).flatmap(
    lambda k: st.tuples(st.just(k), mutated(SEEDS[k]))))
@example(case=("ascii.ply", SEEDS["ascii.ply"].replace(b"vertex_indices", b"\x00ertex_indices")))
def test_mesh_reader_never_crashes(case):
    from dressmeup.io.mesh import load_mesh

    kind, data = case
    path = _write("fuzz." + kind.split(".")[-1], data)
    try:
        with bounded_memory():
            m = load_mesh(path)
    except InputError:
        return
    assert m.vertices.ndim == 2 and m.vertices.shape[1] == 3 and np.isfinite(m.vertices).all()
    assert m.faces.min() >= 0 and m.faces.max() < len(m.vertices)


@FUZZ
@given(mutated(SEEDS["npz"]))
def test_npz_reader_never_crashes(data):
    from dressmeup.io.npz import load_npz

    path = _write("fuzz.npz", data)
    try:
        with bounded_memory():
            arrays = load_npz(path, max_bytes=1 << 20)
    except InputError:
        return
    assert all(isinstance(a, np.ndarray) and not a.dtype.hasobject for a in arrays.values())


@FUZZ
@given(mutated(SEEDS["npy"]))
@example(data=SEEDS["npy"].replace(b"(4, 3)", b"(9999999999, 3)"))
def test_npy_reader_never_crashes(data):
    from dressmeup.io.npz import load_npy

    path = _write("fuzz.npy", data)
    try:
        with bounded_memory():
            a = load_npy(path)
    except InputError:
        return
    assert isinstance(a, np.ndarray) and not a.dtype.hasobject


def _laughs() -> bytes:
    from tests.io.test_io_bombs import laughs

    return laughs()


@FUZZ
@given(st.sampled_from(["pkl", "pkl4"]).flatmap(mutated_seed) | st.just(b"laughs"))
def test_pickle_reader_never_crashes(data):
    from dressmeup.body.safe_pickle import safe_load_pickle

    path = _write("fuzz.pkl", _laughs() if data == b"laughs" else data)
    try:
        with bounded_memory():
            safe_load_pickle(path)
    except InputError:
        return


@FUZZ
@given(mutated(SEEDS["parquet"]))
def test_parquet_reader_never_crashes(data):
    from dressmeup.io.tables import read_table

    path = _write("fuzz.parquet", data)
    try:
        with bounded_memory():
            t = read_table(path)
    except InputError:
        return
    assert t.num_rows >= 0


@FUZZ
@given(mutated(SEEDS["png"]))
def test_image_reader_never_crashes(data):
    from dressmeup.io.images import read_image

    path = _write("fuzz.png", data)
    try:
        with bounded_memory():
            img = read_image(path)
    except InputError:
        return
    assert img.ndim == 3 and img.shape[2] == 3


json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False) | st.text(max_size=8),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(
        st.sampled_from(["name", "format", "manifest_version", "schema", "edition", "metrics",
                         "counts", "garments", "subject_id", "pose_id", "mean", "n", "x"]),
        inner, max_size=5),
    max_leaves=20)


@FUZZ
@given(json_values, st.sampled_from(["dataset", "result", "submission", "session",
                                     "keypoints"]))
def test_json_schemas_report_instead_of_raising(value, schema):
    from dressmeup.io.jsonio import schema_problems, validate_json

    problems = schema_problems(value, schema, "f.json")
    assert all(p.startswith("f.json: field ") for p in problems)
    if problems:
        try:
            validate_json(value, schema, "f.json")
        except InputError:
            return
        raise AssertionError("validate_json accepted what schema_problems refused")


@FUZZ
@given(st.one_of(st.binary(max_size=200),
                 json_values.map(lambda v: json.dumps(v).encode())))
def test_json_file_reader_never_crashes(data):
    from dressmeup.io.jsonio import read_json

    path = _write("fuzz.json", data)
    try:
        with bounded_memory():
            read_json(path, "dataset")
    except InputError:
        pass
