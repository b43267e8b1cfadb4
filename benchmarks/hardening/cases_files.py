"""Every input file the command line reads: missing, empty, truncated, random bytes, of the
wrong kind, a folder, bombed (declaring or inflating to gigabytes), deeply nested.

Each reader is one command line with ``{W}/<name>`` standing for the file under test; the
makers in :mod:`bad_files` write the damaged file there before the run.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import bad_files as bf
import cases_bench
from cases_common import _fx, _standard
from runner import Case

F, W = "{F}", "{W}"


def _dataset_copy(damage):
    def setup(w: Path) -> None:
        d = bf.copy_tree(_fx(w) / "data", w / "data")
        damage(d)
    return setup


def _garment(d: Path) -> Path:
    return d / "samples" / "S01" / "G01" / "P0" / "garment.ply"


def _session_copy(damage):
    def setup(w: Path) -> None:
        d = bf.copy_tree(_fx(w) / "session", w / "session")
        damage(d)
    return setup


def _colour(d: Path) -> Path:
    return sorted((d / "cam0" / "color").glob("*.png"))[0]


def _depth(d: Path) -> Path:
    return sorted((d / "cam0" / "depth").glob("*.png"))[0]


def mesh_cases() -> list[Case]:
    out = []
    for argv, name in ((["metrics", "@", f"{F}/garment.ply", "--samples", "1000"], "pred.ply"),
                       (["metrics", "@", f"{F}/garment.obj", "--samples", "1000"], "pred.obj"),
                       (["metrics", f"{F}/garment.ply", f"{F}/garment.ply", "--samples",
                         "1000", "--body", "@"], "body.ply")):
        out += _standard("files", argv, name, "garment" + name[-4:], [
            ("faces of zero area", lambda w, n=name: _zero_area(w / n)),
            ("declares 10^12 vertices", lambda w, n=name: _ply_header_bomb(w / n)),
            ("a JSON", lambda w, n=name: bf.json_file(w / n, {"vertices": []})),
        ])
    out.append(Case("files", "metrics: prediction in mm, ground truth in m",
                    ["metrics", f"{F}/garment_mm.ply", f"{F}/garment.ply", "--samples", "1000"],
                    "warn:millimet"))
    return out


def _zero_area(p: Path) -> Path:
    from dressmeup.io.mesh import save_mesh

    V = [[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]]
    save_mesh(p, V, [[0, 1, 2], [1, 2, 3]])
    return p


def _ply_header_bomb(p: Path) -> Path:
    if p.suffix == ".obj":
        p.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 1000000000000\n")
        return p
    p.write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\n"
                  b"property float x\nproperty float y\nproperty float z\nelement face 1\n"
                  b"property list uchar int vertex_indices\nend_header\n" + b"\x00" * 64)
    return p


def register_cases() -> list[Case]:
    base = ["register", "@", "--model", "procedural", "--out", f"{W}/fit.npz",
            "--iterations", "1,1,1", "--no-picture"]
    out = _standard("files", base, "scan.npy", "scan.npy", [
        ("declares (2^33, 3)", lambda w: bf.npy_header_bomb(w / "scan.npy")),
        ("holds objects", lambda w: bf.npy_objects(w / "scan.npy")),
        ("(p, 2) points", lambda w: _np_save(w / "scan.npy", [[0.0, 1.0]] * 50)),
        ("NaN points", lambda w: _np_save(w / "scan.npy", [[float("nan")] * 3] * 50)),
    ])
    out += _standard("files", base, "scan.ply", "garment.ply", [
        ("faces of zero area", lambda w: _zero_area(w / "scan.ply")),
        ("declares 10^12 vertices", lambda w: _ply_header_bomb(w / "scan.ply")),
    ])
    out.append(Case("files", "register scan.xyz: words", base[:1] + [f"{W}/scan.xyz"] + base[2:],
                    "refuse", setup=lambda w: (w / "scan.xyz").write_text("a b c\nd e f\n")))
    init = [*base[:1], f"{F}/scan.npy", *base[2:], "--init", "@"]
    out += _standard("files", init, "init.npz", "body.npz", [
        ("100,000 members", lambda w: bf.npz_many(w / "init.npz")),
        ("declares 2.4 GB", lambda w: bf.npz_declared(w / "init.npz")),
        ("inflates to 1 GB", lambda w: bf.npz_inflating(w / "init.npz", "pose")),
    ])
    pkl = [*base[:1], f"{F}/scan.npy", *base[2:], "--init", "@", "--format", "pkl"]
    for label, make in (("billion laughs", lambda w: bf.laughs_pickle(w / "init.pkl")),
                        ("nested 200,000 deep", lambda w: bf.deep_pickle(w / "init.pkl")),
                        ("random bytes", lambda w: bf.random_bytes(w / "init.pkl")),
                        ("truncated", lambda w: bf.truncated(
                            _fx(w) / "thuman" / "fits" / "0007" / "smplx_param.pkl",
                            w / "init.pkl"))):
        out.append(Case("files", f"register --init init.pkl: {label}",
                        [a.replace("@", f"{W}/init.pkl") for a in pkl[:-2]], "refuse",
                        setup=make))
    kp = [*base[:1], f"{F}/scan.npy", *base[2:], "--keypoints", "@"]
    out += _standard("files", kp, "kp.json", "keypoints.json", [
        ("80 MB", lambda w: bf.big_json(w / "kp.json")),
        ("nested 100,000 deep", lambda w: bf.deep_json(w / "kp.json")),
        ("a list", lambda w: bf.json_file(w / "kp.json", [[0, 1, 2]])),
    ])
    return out


def _np_save(p: Path, value) -> Path:
    import numpy as np

    np.save(p, np.asarray(value))
    return p


def dataset_cases() -> list[Case]:
    v = ["validate-dataset", f"{W}/data"]
    damages = {
        "dataset.json random bytes": lambda d: bf.random_bytes(d / "dataset.json"),
        "dataset.json empty": lambda d: bf.empty(d / "dataset.json"),
        "dataset.json a list": lambda d: bf.json_file(d / "dataset.json", [1, 2]),
        "dataset.json 80 MB": lambda d: bf.big_json(d / "dataset.json"),
        "dataset.json nested deep": lambda d: bf.deep_json(d / "dataset.json"),
        "manifest random bytes": lambda d: bf.random_bytes(d / "manifest.parquet"),
        "manifest truncated": lambda d: bf.truncated(d / "manifest.parquet",
                                                     d / "manifest.parquet"),
        "manifest empty": lambda d: bf.empty(d / "manifest.parquet"),
        "garment truncated": lambda d: bf.truncated(_garment(d), _garment(d)),
        "garment random bytes": lambda d: bf.random_bytes(_garment(d)),
        "garment a folder": lambda d: (_garment(d).unlink(), _garment(d).mkdir()),
        "body.npz 100,000 members": lambda d: bf.npz_many(_garment(d).with_name("body.npz")),
        "body.npz inflates to 1 GB": lambda d: bf.npz_inflating(
            _garment(d).with_name("body.npz"), "pose"),
        "symlink loop in samples": lambda d: bf.symlink_loop(d / "samples" / "S01"),
        "samples a file": lambda d: (shutil.rmtree(d / "samples"),
                                     bf.empty(d / "samples")),
    }
    out = []
    for label, damage in damages.items():
        for extra in ([], ["--no-meshes"]):
            out.append(Case("files", f"validate-dataset{' --no-meshes' if extra else ''}: "
                            f"{label}", v + extra, "refuse", setup=_dataset_copy(damage),
                            timeout=90))
    out.append(Case("files", "validate-dataset --no-meshes: manifest of 2 million rows",
                    v + ["--no-meshes", "--no-hashes"], "refuse", timeout=120,
                    setup=_dataset_copy(lambda d: bf.parquet_rows(
                        d / "manifest.parquet", _fx(d.parent) / "data" / "manifest.parquet"))))
    for label, make in (("40000x40000 PNG bomb", lambda p: bf.png_bomb(p)),
                        ("random bytes", lambda p: bf.random_bytes(p))):
        out.append(Case("files", f"validate-dataset: texture of {label}", v + ["--no-hashes"],
                        "refuse", setup=_dataset_copy(lambda d, m=make: _with_texture(d, m)),
                        timeout=90))
    return out


def _with_texture(d: Path, make) -> None:
    """Give the first sample a texture (a valid PNG in the manifest), then damage it."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    from dressmeup.io.hashing import sha256_file

    tex = _garment(d).with_name("texture.png")
    make(tex)
    t = pq.read_table(d / "manifest.parquet")
    rel = str(tex.relative_to(d))
    paths = t.column("texture_path").to_pylist()
    hashes = t.column("texture_sha256").to_pylist()
    paths[0], hashes[0] = rel, sha256_file(tex)
    t = t.set_column(t.column_names.index("texture_path"), t.schema.field("texture_path"),
                     pa.array(paths, pa.string()))
    t = t.set_column(t.column_names.index("texture_sha256"), t.schema.field("texture_sha256"),
                     pa.array(hashes, pa.string()))
    pq.write_table(t, d / "manifest.parquet")


def session_cases() -> list[Case]:
    out = []
    damages = {
        "rig.json random bytes": lambda d: bf.random_bytes(d / "rig.json"),
        "rig.json 80 MB": lambda d: bf.big_json(d / "rig.json"),
        "rig.json nested deep": lambda d: bf.deep_json(d / "rig.json"),
        "session.json 80 MB": lambda d: bf.big_json(d / "session.json"),
        "session.json a list": lambda d: bf.json_file(d / "session.json", [1]),
        "session.json not UTF-8": lambda d: (d / "session.json").write_bytes(b"\xff\xfe{}"),
        "session.json nested deep": lambda d: bf.deep_json(d / "session.json"),
        "colour PNG bomb": lambda d: bf.png_bomb(_colour(d)),
        "colour random bytes": lambda d: bf.random_bytes(_colour(d)),
        "depth truncated": lambda d: bf.truncated(_depth(d), _depth(d)),
        "camera folder a symlink loop": lambda d: (shutil.rmtree(d / "cam1"),
                                                   bf.symlink_loop(d) and
                                                   (d / "cam1").symlink_to(d / "loop_a")),
    }
    for label, damage in damages.items():
        out.append(Case("files", f"validate-session: {label}", ["validate-session",
                        f"{W}/session"], "refuse", setup=_session_copy(damage)))
        out.append(Case("files", f"fuse: {label}", ["fuse", f"{W}/session", "--out",
                        f"{W}/scan", "--voxel", "0.02"], "refuse", setup=_session_copy(damage)))
    out += _standard("files", ["synth-capture", "mannequin", "--out", f"{W}/s", "--scale",
                               "0.2", "--rig", "@"], "rig.json", "session/rig.json",
                     [("80 MB", lambda w: bf.big_json(w / "rig.json"))])
    return out


def adapter_cases() -> list[Case]:
    def take(w: Path) -> Path:
        src = bf.copy_tree(_fx(w) / "4ddress", w / "4ddress")
        return src / "00122" / "Inner" / "Take2"

    def label_file(w: Path) -> Path:
        t = take(w)
        for cloth in (t / "Semantic" / "clothes").glob("*.pkl"):
            cloth.unlink()  # garments cut by the labels: the label files are read
        return t / "Semantic" / "labels" / "label-f00011.pkl"

    def mesh_file(w: Path) -> Path:
        return take(w) / "Meshes_pkl" / "mesh-f00011.pkl"

    def edit_mesh(fn):
        def setup(w: Path) -> None:
            import pickle

            p = mesh_file(w)
            m = pickle.loads(p.read_bytes())
            fn(m)
            bf.pickle_of(p, m)
        return setup

    imp = ["import-dataset", "4ddress", f"{W}/4ddress", "--out", f"{W}/out"]
    cases = {
        "label file a billion laughs": lambda w: bf.laughs_pickle(label_file(w)),
        "label file nested deep": lambda w: bf.deep_pickle(label_file(w)),
        "labels as strings": lambda w: bf.pickle_of(label_file(w), {"scan_labels": ["a"] * 36}),
        "label file missing key": lambda w: bf.pickle_of(label_file(w), {"x": 1}),
        "label file random bytes": lambda w: bf.random_bytes(label_file(w)),
        "mesh faces out of range": edit_mesh(lambda m: m["faces"].__setitem__(0, [0, 1, 10**6])),
        "mesh without faces": edit_mesh(lambda m: m.pop("faces")),
        "mesh vertices as text": edit_mesh(lambda m: m.__setitem__("vertices", "abc")),
        "mesh truncated": lambda w: bf.truncated(mesh_file(w), mesh_file(w)),
        "basic_info a list": lambda w: bf.pickle_of(take(w) / "basic_info.pkl", [1, 2]),
    }
    out = [Case("files", f"import-dataset 4ddress: {k}", imp, "refuse", setup=v)
           for k, v in cases.items()]

    def thuman(w: Path) -> Path:
        return bf.copy_tree(_fx(w) / "thuman", w / "thuman")

    def laughs(w: Path) -> None:
        bf.laughs_pickle(thuman(w) / "fits" / "0007" / "smplx_param.pkl")

    def collide(w: Path) -> None:
        t = thuman(w)
        (t / "scans" / "0007").rename(t / "scans" / "a b")
        (t / "scans" / "a b" / "0007.obj").rename(t / "scans" / "a b" / "a b.obj")
        (t / "scans" / "0008").rename(t / "scans" / "a_b")
        (t / "scans" / "a_b" / "0008.obj").rename(t / "scans" / "a_b" / "a_b.obj")

    th = ["import-dataset", "thuman", f"{W}/thuman/scans", "--smplx", f"{W}/thuman/fits",
          "--out", f"{W}/out"]
    out.append(Case("files", "import-dataset thuman: smplx_param.pkl a billion laughs", th,
                    "refuse", setup=laughs))
    out.append(Case("files", "import-dataset thuman: scans 'a b' and 'a_b'",
                    th[:4] + ["--no-body", "--out", f"{W}/out"], "either", setup=collide,
                    check=_two_samples))
    return out


def _two_samples(w: Path, results) -> str | None:
    if results[0].status != 0:
        return None
    import pyarrow.parquet as pq

    n = pq.read_table(w / "out" / "manifest.parquet").num_rows
    return None if n == 2 else f"{n} sample(s) written for two scans"


def cases() -> list[Case]:
    """Every bad-file case."""
    return (mesh_cases() + register_cases() + dataset_cases() + session_cases()
            + adapter_cases() + cases_bench.cases())
