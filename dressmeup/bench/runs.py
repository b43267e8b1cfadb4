"""Library side of ``dressmeup demo`` and ``benchmarks/run_baselines.py``: build an edition's
data, run the reference baselines into submissions, score them, make leaderboards.

Each step logs one line per thing done or skipped through ``log`` (the CLI prints them).
Baselines are discovered through the method registries (``dressmeup.methods.retarget`` /
``dressmeup.methods.uvparam``); a stage that is not installed is skipped with a clear line.
"""

from __future__ import annotations

import importlib
import inspect
import os
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from dressmeup.bench.edition import Edition, load_edition
from dressmeup.bench.provenance import hardware
from dressmeup.errors import InputError

Log = Callable[[str], Any]


def _quiet(_line: str) -> None:
    return None


#: ``submission.json`` ``authors`` of the toolkit's reference baselines.
BASELINE_AUTHORS = "dressmeup reference baselines"


class SkippedBaseline(InputError):
    """A baseline that cannot run in this configuration (the message says why and what to do)."""


def _shipped_weights(method: Any, body_model: str) -> Path | None:
    """The checkpoint a trainable method ships for ``body_model`` (None when there is none)."""
    mod = importlib.import_module(type(method).__module__)
    wdir = getattr(mod, "WEIGHTS_DIR", None)
    if wdir is None:
        return None
    stem = getattr(getattr(method, "method", method), "weights_stem", None)  # a chain's base method
    hits = sorted(Path(wdir).glob(f"{stem}_{body_model}.pt" if stem else f"*_{body_model}.pt"))
    return hits[0] if hits else None


def build_data(edition: str | Edition, root: str | os.PathLike, log: Log = _quiet) -> Path:
    """Generate (or resume) the data an edition pins into ``root``.

    ``retarget`` editions of the synthetic generator call
    :func:`dressmeup.data.synth.generate_dataset` with the pinned parameters and seed;
    ``uvparam`` editions build their mesh set. Real datasets cannot be generated.

    Raises
    ------
    InputError
        For editions of real datasets or unknown generators.
    """
    ed = load_edition(edition)
    root = Path(root)
    pin = ed.dataset
    if pin.kind != "generated":
        raise InputError(f"edition {ed.name} is scored on a real dataset (manifest "
                         f"{pin.manifest_sha256[:12]}...); it cannot be generated")
    t0 = time.perf_counter()
    if ed.task == "uvparam":
        from dressmeup.bench.tasks.uvparam.data import build_mesh_set

        build_mesh_set(root, edition=ed)
    else:
        from dressmeup.data.synth import generate_dataset

        accepted = set(inspect.signature(generate_dataset).parameters)
        unknown = sorted(set(pin.params) - accepted)
        if unknown:
            raise InputError(f"edition {ed.name}: generator parameters {unknown} are not "
                             f"accepted by this toolkit's generate_dataset")
        generate_dataset(root, seed=pin.seed, **pin.params)
    log(f"data for {ed.name}: {root} ({time.perf_counter() - t0:.0f} s)")
    other = data_differs(ed, root)
    if other:
        log(f"warning: {other}. This machine generates other data than the one that pinned "
            "the edition (docs/synthetic-data.md, 'Reproducibility'); scores on it are marked "
            "not comparable")
    return root


def data_differs(edition: str | Edition, root: str | os.PathLike) -> str | None:
    """Why the generated data at ``root`` are not the data ``edition`` pins (its
    ``expected_manifest_sha256``), or None when they are or the edition pins no manifest."""
    from dressmeup.bench.score import other_data_reason
    from dressmeup.bench.tasks.common import manifest_sha256

    ed = load_edition(edition)
    if not (Path(root) / "manifest.parquet").is_file():
        return None
    return other_data_reason(ed, {"manifest_sha256": manifest_sha256(root)}, root)


def retarget_methods() -> list[str]:
    """Names of the retargeting baselines this installation provides ([] when none)."""
    try:
        mod = importlib.import_module("dressmeup.methods.retarget")
    except ImportError:
        return []
    names = getattr(mod, "available_methods", None)
    return list(names()) if callable(names) else list(getattr(mod, "METHODS", {}))


def uvparam_methods() -> list[str]:
    """Names of the UV baselines this installation provides ([] when none)."""
    try:
        mod = importlib.import_module("dressmeup.methods.uvparam")
    except ImportError:
        return []
    return list(getattr(mod, "METHODS", {}))


def run_retarget_baseline(method_name: str, edition: str | Edition, data_root: str | os.PathLike,
                          out: str | os.PathLike, *, train_steps: int = 150,
                          max_triplets: int = 8, limit: int | None = None, url: str = "",
                          overwrite: bool = False, log: Log = _quiet, executor: Any = None,
                          **hyperparameters: Any) -> Path:
    """Run one retargeting baseline over the edition's pairs into a submission folder.

    ``executor`` (:mod:`dressmeup.executors`) runs one job per pair (default: in this
    process); training, when any, runs here first.

    The one path from a retargeting method to a submission: ``dressmeup baseline retarget``,
    ``dressmeup demo`` and ``benchmarks/run_baselines.py`` all come here, so every
    submission records its hardware (:func:`dressmeup.bench.provenance.hardware`) and
    hyperparameters the same way.

    Trainable methods (with ``fit``) use the weights they ship for the dataset's body model,
    or ``weights=`` given as a hyperparameter; without either they are first trained
    self-supervised on the ``train`` split (``train_steps`` steps over ``max_triplets``
    triplets; no ground truth is read), or skipped when ``train_steps`` is 0.

    Parameters
    ----------
    method_name : a name of :func:`dressmeup.methods.retarget.get_method` (``+`` chains).
    edition, data_root, out : the edition, its data and the submission folder to write.
    train_steps, max_triplets : training of trainable methods without weights (see above).
    limit : only the first ``limit`` pairs (an incomplete submission, for smoke tests).
    url : ``submission.json`` ``url``.
    overwrite : write into a non-empty ``out``.
    log : called with one line per thing done.
    **hyperparameters : passed to the method (recorded with ``repr``).

    Raises
    ------
    SkippedBaseline
        A trainable method without weights while training is off (the message says how
        to train it).
    """
    from dressmeup.bench.submission import write_submission
    from dressmeup.data import Dataset
    from dressmeup.methods.retarget import get_method
    from dressmeup.methods.retarget.run import predict_pairs, training_triplets

    ed = load_edition(edition)
    ds = Dataset(data_root)
    method = get_method(method_name, **hyperparameters)
    trained = ""
    if hasattr(method, "fit") and "weights" not in hyperparameters:
        body_model = ds[0].body().model
        shipped = _shipped_weights(method, body_model)
        if shipped is not None:
            trained = f", shipped weights {shipped.name}"
        elif train_steps <= 0:
            raise SkippedBaseline(
                f"trainable and no shipped weights for the {body_model} body; training is off "
                f"here (train with 'dressmeup baseline train-retarget --data {data_root} "
                f"--out w.pt', then '--weights w.pt')")
        else:
            if "steps" in inspect.signature(type(method).__init__).parameters and \
                    "steps" not in hyperparameters:
                method = get_method(method_name, steps=train_steps, **hyperparameters)
            t0 = time.perf_counter()
            supervised = bool(getattr(getattr(method, "method", method), "supervised", False))
            triplets, model = training_triplets(ds, "train", max_triplets, seed=0, with_truth=supervised)
            method.fit(triplets, model)
            trained = (f", trained {train_steps} steps ({time.perf_counter() - t0:.0f} s) on "
                       f"{len(triplets)} train-split triplets")
    from dressmeup.bench.tasks.retarget.data import edition_pairs

    if executor is not None:
        from dressmeup.executors import require_shared

        require_shared(executor, data_root)
    preds, seconds = predict_pairs(method, edition_pairs(ed, ds), limit=limit,
                                   executor=executor)
    runtime = float(np.mean(seconds)) if seconds else 0.0
    path = write_submission(out, preds, edition=ed, method=method_name,
                            authors=BASELINE_AUTHORS, url=url,
                            hardware=hardware(), runtime_per_sample_s=runtime,
                            extra={"hyperparameters": {k: repr(v)
                                                       for k, v in hyperparameters.items()}},
                            overwrite=overwrite)
    log(f"  {method_name}: {len(preds)} pairs, {runtime:.2f} s/pair{trained}")
    return path


class UVMeshJob:
    """One mesh's job for an executor: ``job(mesh_record) -> UVResult`` (picklable when the
    method is; runs on a pool or Dask worker)."""

    __name__ = "uvparam_mesh"

    def __init__(self, method: Any) -> None:
        self.method = method
        self.takes_category = "category" in inspect.signature(method.parameterize).parameters

    def __call__(self, m: Any) -> Any:
        from dressmeup.io.mesh import load_mesh

        mesh = load_mesh(m.path)
        kw = {"category": m.category} if self.takes_category else {}
        return self.method.parameterize(mesh.vertices, mesh.faces, **kw)


def run_uvparam_baseline(method_name: str, edition: str | Edition, data_root: str | os.PathLike,
                         out: str | os.PathLike, *, log: Log = _quiet, executor: Any = None,
                         overwrite: bool = False, **hyperparameters: Any) -> Path:
    """Run one UV baseline over the edition's meshes into a submission folder.

    The one path from a UV method to a submission of an edition's mesh set
    (``dressmeup baseline uvparam --data``, ``dressmeup demo``, ``benchmarks/run_baselines.py``).
    ``executor`` (:mod:`dressmeup.executors`) runs one job per mesh (default: in this
    process); the first mesh that fails fails the run, as in the loop. Hyperparameters, when
    given, are recorded in ``submission.json`` with ``repr``; ``overwrite`` writes into a
    non-empty ``out``."""
    from dressmeup.bench.submission import write_submission
    from dressmeup.bench.tasks.uvparam.data import meshes
    from dressmeup.executors import LocalExecutor, in_order, require_shared
    from dressmeup.methods.uvparam import get_method
    from dressmeup.progress import progress

    ed = load_edition(edition)
    method = get_method(method_name, **hyperparameters)
    records = list(meshes(data_root, ed.split))
    executor = executor or LocalExecutor(1)
    require_shared(executor, data_root)
    preds, secs, tracks = {}, [], set()
    done = progress(executor.run(UVMeshJob(method), records), desc=f"uvparam {method_name}",
                    total=len(records))
    for i, res in in_order(done):
        if isinstance(res, BaseException):
            raise res
        m = records[i]
        preds[m.mesh_id] = {"uv": res.uv, "uv_faces": res.uv_faces,
                            "chart_ids": res.chart_ids, "seconds": np.float64(res.seconds)}
        secs.append(res.seconds)
        # methods that optimise on the mesh report nothing: they are per-mesh
        tracks.add(res.info.get("track", "per-mesh"))
    runtime = float(np.mean(secs)) if secs else 0.0
    # the pretrained track only when every mesh was unseen by the method (checked, not declared)
    extra = {"track": "pretrained" if tracks == {"pretrained"} else "per-mesh"} \
        if getattr(ed, "tracks", None) else {}
    if hyperparameters:
        extra["hyperparameters"] = {k: repr(v) for k, v in hyperparameters.items()}
    path = write_submission(out, preds, edition=ed, method=method_name,
                            authors=BASELINE_AUTHORS, url="",
                            hardware=hardware(), runtime_per_sample_s=runtime, extra=extra or None,
                            overwrite=overwrite)
    log(f"  {method_name}: {len(preds)} meshes, {runtime:.2f} s/mesh")
    return path


def registration_methods() -> list[str]:
    """Names of the registration baselines: ``register``, the toolkit's registrar with its
    default options (:func:`dressmeup.body.registration.register`)."""
    return ["register"]


class RegisterJob:
    """One registration fit for an executor (:mod:`dressmeup.executors`):
    ``RegisterJob(data_root, options)(sample_id) -> (body-parameter arrays, CPU seconds)``;
    the scan is the sample's ``scan.ply``, the body model the one of its true body."""

    __name__ = "register"

    def __init__(self, data_root: str | os.PathLike, options: dict[str, Any]) -> None:
        self.data_root, self.options = str(data_root), dict(options)

    def __call__(self, sample_id: str) -> tuple[dict[str, np.ndarray], float]:
        from dressmeup.bench.tasks.common import open_dataset
        from dressmeup.body import get_body_model
        from dressmeup.body.registration import register

        sample = open_dataset(self.data_root)[sample_id]
        scan = sample.scan()
        if scan is None:
            raise InputError(f"sample {sample_id} of {self.data_root} has no scan.ply to register")
        t0 = time.process_time()
        # quiet by default: one progress bar per scan inside a job would flood the run's log
        options = {"verbose": False, **self.options}
        p = register(scan, get_body_model(sample.body().model), **options)
        arrays = {"model": np.array(p.model), "gender": np.array(p.gender), "shape": p.shape,
                  "pose": p.pose, "transl": p.transl, "scale": np.array(p.scale, np.float64)}
        return arrays, time.process_time() - t0


def run_registration_baseline(method_name: str, edition: str | Edition,
                              data_root: str | os.PathLike, out: str | os.PathLike, *,
                              log: Log = _quiet, executor: Any = None, overwrite: bool = False,
                              **options: Any) -> Path:
    """Fit the body model to every scan of the edition's split into a submission folder.

    ``method_name`` is ``register`` (:func:`registration_methods`); ``options`` go to
    :func:`dressmeup.body.registration.register` (recorded in ``submission.json``).
    ``executor`` runs one job per scan (default: in this process); ``runtime_per_sample_s``
    is the mean CPU seconds of one fit."""
    from dressmeup.bench.submission import write_submission
    from dressmeup.bench.tasks.registration.data import items
    from dressmeup.executors import LocalExecutor, in_order, require_shared
    from dressmeup.progress import progress

    if method_name not in registration_methods():
        raise InputError(f"registration baseline {method_name!r}: known "
                         f"{registration_methods()}")
    ed = load_edition(edition)
    ids = [it.item_id for it in items(ed, Path(data_root))]
    executor = executor or LocalExecutor(1)
    require_shared(executor, data_root)
    preds, cpu = {}, []
    done = progress(executor.run(RegisterJob(data_root, options), ids),
                    desc=f"registration {method_name}", total=len(ids))
    for i, res in in_order(done):
        if isinstance(res, BaseException):
            raise res
        preds[ids[i]], sec = res
        cpu.append(sec)
    runtime = float(np.mean(cpu)) if cpu else 0.0
    extra = {"hyperparameters": {k: repr(v) for k, v in options.items()}} if options else None
    path = write_submission(out, preds, edition=ed, method=method_name,
                            authors=BASELINE_AUTHORS, url="", hardware=hardware(),
                            runtime_per_sample_s=runtime, extra=extra, overwrite=overwrite)
    log(f"  {method_name}: {len(preds)} scans, {runtime:.1f} CPU-s/scan")
    return path


def run_baselines(edition: str | Edition, data_root: str | os.PathLike,
                  sub_dir: str | os.PathLike, methods: Sequence[str] | None = None,
                  log: Log = _quiet, **kw: Any) -> dict[str, Path]:
    """Run every available baseline of the edition's task (or ``methods``); a method that
    fails is reported and skipped. Returns method name -> submission folder."""
    ed = load_edition(edition)
    if ed.task == "retarget":
        names, runner = retarget_methods(), run_retarget_baseline
    elif ed.task == "uvparam":
        names, runner = uvparam_methods(), run_uvparam_baseline
    elif ed.task == "registration":
        names, runner = registration_methods(), run_registration_baseline
    else:
        log(f"no reference baselines for task {ed.task} in this toolkit: skipped")
        return {}
    if not names:
        log(f"no {ed.task} baselines installed (dressmeup.methods.{ed.task}): skipped")
        return {}
    chosen = list(methods) if methods is not None else names
    subs: dict[str, Path] = {}
    for name in chosen:
        try:
            subs[name] = runner(name, ed, data_root, Path(sub_dir) / name.replace("+", "_"),
                                log=log, **kw)
        except SkippedBaseline as exc:
            log(f"  {name}: skipped ({exc})")
        except Exception as exc:  # noqa: BLE001 - one broken baseline must not stop the others
            log(f"  {name}: FAILED ({type(exc).__name__}: {exc}); skipped")
    return subs


def score_many(subs: dict[str, Path], edition: str | Edition, data_root: str | os.PathLike,
               results_dir: str | os.PathLike, workers: int | None = None, executor: Any = None,
               log: Log = _quiet, allow_other_data: bool = False) -> list[Path]:
    """Score each submission into ``results_dir/<name>`` (new folders); return the folders.
    ``allow_other_data``: score data that differ from the edition's pin, marked not
    comparable (see :func:`~dressmeup.bench.score.score_submission`)."""
    from dressmeup.bench.leaderboard import format_summary
    from dressmeup.bench.score import score_submission

    out = []
    for sub in subs.values():
        res = score_submission(sub, edition, data_root, Path(results_dir) / sub.name,
                               workers=workers, executor=executor,
                               allow_other_data=allow_other_data)
        log(format_summary(res.summary))
        out.append(res.path)
    return out
