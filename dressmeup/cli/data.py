"""Subcommands of the data stage: ``synth`` (build the synthetic dataset),
``validate-dataset`` (check a dataset folder, report every problem) and ``import-dataset``
(write a published dataset as a DressMeUp-style folder)."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from dressmeup.cli.checks import integer, new_output, number, seed
from dressmeup.cli.executor_args import add_executor_args, executor_from_args
from dressmeup.errors import InputError
from dressmeup.limits import MESH_FACES, SAMPLES

#: Largest garment surface the generator makes (a long dress, both sides), m^2: with an
#: edge length e a garment has about 2.31 * area / e^2 triangles (equilateral ones).
_GARMENT_AREA_M2 = 2.0


def register(subparsers: argparse._SubParsersAction) -> None:
    """Register ``synth`` and ``validate-dataset``."""
    p = subparsers.add_parser(
        "synth", help="generate the built-in synthetic DressMeUp-style dataset",
        description="Generate a synthetic dataset: bodies of varied shape in varied poses, "
                    "parametric garments draped by skinning + quasi-static cloth relaxation. "
                    "Deterministic for a seed; re-running on the same OUT resumes.")
    p.add_argument("out", type=new_output,
                   help="output dataset folder (created; resumed when it exists)")
    p.add_argument("--subjects", type=integer(1), default=3,
                   help="number of subjects (default 3)")
    p.add_argument("--garments", type=integer(1), default=4,
                   help="garments per subject (default 4)")
    p.add_argument("--poses", type=integer(1), default=5, help="poses per garment (default 5)")
    p.add_argument("--seed", type=seed, default=0, help="random seed (default 0)")
    p.add_argument("--body-model", default="anny", choices=["anny", "procedural"],
                   help="body model (default anny; procedural is tiny, for tests)")
    p.add_argument("--registration-noise", type=number(0.0, math.pi), default=0.0,
                   metavar="SIGMA",
                   help="std of Gaussian noise added to the stored body pose (radians) and "
                        "shape; 0 stores the true parameters (default)")
    p.add_argument("--edge-length", type=number(0.0, 1.0, lo_open=True), default=None,
                   help="target garment edge length in metres (default: by body model)")
    p.add_argument("--no-scan", action="store_true", help="do not write clothed scan meshes")
    p.add_argument("--edition", default=None,
                   help="generate exactly the data this edition pins (e.g. synth-retarget-v3; "
                        "the options above are then taken from the edition) and check its "
                        "manifest against the edition's expected sha256; a v3 edition "
                        "(generator 2.1.0, whose bytes depend on the CPU) is first probed: "
                        "where this machine would write other data it stops and names the "
                        "way to the pinned data")
    p.add_argument("--allow-other-data", action="store_true",
                   help="with --edition: generate even where this machine writes other data "
                        "than the edition pins (its scores are then not comparable)")
    p.add_argument("--secret", default=None, metavar="FILE",
                   help="with --edition: the secret that seeds the edition's test split "
                        "(its maintainers'); checked against the edition's commitment before "
                        "any work. Without it, an edition whose test split is secret is "
                        "generated without its test split (docs/benchmark.md, 'Secret test "
                        "splits')")
    p.add_argument("--designed-garments", action="store_true",
                   help="with a generator-4 --edition (...-v5): write only its garments as "
                        "designed (generator/rest/<G>.ply, what the neural UV models train "
                        "on, the same bytes as a full generation's) and generator/"
                        "designed.json, without simulating any target: minutes, not hours")
    add_executor_args(p, default_workers=1,
                      what="garment of generators 2.x and 3.x (--edition ...-v3, ...-v4), "
                           "per target of generator 4.x (...-v5); the data do not depend on "
                           "where they run")
    p.set_defaults(func=_synth, locks=("out",))

    v = subparsers.add_parser(
        "validate-dataset", help="check a dataset folder and report every problem",
        description="Check dataset.json, the manifest schema, files, checksums, meshes, body "
                    "files and splits; print every problem; exit 1 when any is found.")
    v.add_argument("root", help="dataset folder")
    v.add_argument("--no-hashes", action="store_true", help="skip sha256 checks")
    v.add_argument("--no-meshes", action="store_true", help="skip loading meshes and bodies")
    v.set_defaults(func=_validate)

    i = subparsers.add_parser(
        "import-dataset", help="import CLOTH3D, 4D-DRESS or THuman2.x into a dataset folder",
        description="Read a published dataset with its adapter (conventions of the official "
                    "readers: docs/dataset-format.md), write it as a DressMeUp-style dataset "
                    "(splits by garment, sha256 per file, resumable) and report what was found "
                    "and skipped. Zero samples is an error.")
    i.add_argument("kind", choices=["cloth3d", "4ddress", "thuman"], help="published dataset")
    i.add_argument("root", help="its folder (THuman: the scans folder)")
    i.add_argument("--out", required=True, type=new_output,
                   help="dataset folder to write (resumed if it exists)")
    i.add_argument("--split", default="by-garment", choices=["by-garment", "train", "val", "test"],
                   help="by-garment: 60/20/20 stratified by category, seeded (default); or one "
                        "split for every sample")
    i.add_argument("--seed", type=seed, default=0, help="split seed (default 0)")
    i.add_argument("--frames", default=None,
                   help="comma-separated frames to keep (CLOTH3D: indices; 4D-DRESS: names as "
                        "in the files, e.g. 00011); default all (CLOTH3D: every --stride-th)")
    i.add_argument("--stride", type=integer(1), default=10,
                   help="CLOTH3D frame step (default 10)")
    i.add_argument("--smplx", default=None, help="THuman: folder of <id>/smplx_param.pkl fits")
    i.add_argument("--gender", default=None, choices=["male", "female", "neutral"],
                   help="body gender (default: the dataset's convention: 4D-DRESS official "
                        "per-subject list, THuman male as ICON, CLOTH3D from info.mat)")
    i.add_argument("--convention", default="auto", choices=["auto", "icon", "transl"],
                   help="THuman fit placement: icon = model*scale+translation (2.0), transl = "
                        "model+transl (2.1 loaders), auto = by the fit's keys (default)")
    i.add_argument("--smpl-model", default=None, metavar="PATH",
                   help="SMPL/SMPL-X model file or folder (bodies of CLOTH3D need it; pictures "
                        "of every dataset use it)")
    i.add_argument("--no-body", action="store_true", help="write garments without bodies")
    i.add_argument("--pictures", type=integer(0), default=0, metavar="N",
                   help="also draw the first N samples (garment on body, front and side) into "
                        "OUT/pictures/")
    i.set_defaults(func=_import, locks=("out",))


def _generator_1_is_serial(args: argparse.Namespace) -> None:
    if args.executor or args.scheduler or (args.workers or 1) > 1:
        raise InputError("--executor/--workers/--scheduler run generators 2.x, 3.x and 4.x "
                         "(--edition ...-v3, ...-v4, ...-v5) in parallel; generator 1.1.0 runs "
                         "in this process")


def _synth_edition(args: argparse.Namespace) -> int:
    # start-up: the stage loads when the command runs
    from dressmeup.bench.edition import (
        ALL_SPLITS,
        edition_secret,
        load_edition,
        secret_test_split_note,
        splits_to_generate,
    )
    from dressmeup.bench.tasks.common import manifest_sha256
    from dressmeup.data.synth import generate_dataset, synth_config
    from dressmeup.data.synth.config import check_secret_support

    ed = load_edition(args.edition)
    pin = ed.dataset
    if pin.kind != "generated":
        raise InputError(f"--edition {ed.name} is scored on a real dataset; it cannot be generated")
    secret = edition_secret(ed, args.secret)  # a wrong secret is refused before any work
    splits = splits_to_generate(ed, secret)
    config = None
    if ed.task != "uvparam":
        try:
            config = synth_config(**pin.params, seed=pin.seed, secret=secret, splits=splits)
            check_secret_support(config)
        except InputError as exc:
            raise InputError(f"edition {ed.name}: {exc}") from exc
    if args.designed_garments:
        return _designed_garments(args, ed, config)
    if not args.allow_other_data:
        _probe_machine(ed)
    if config is None:  # uvparam: a mesh set, not a garment dataset
        # start-up: the stage loads when the command runs
        from dressmeup.runs import build_data

        root = build_data(ed, args.out, secret_file=args.secret)
    else:
        kw: dict = {}
        if not str(pin.params.get("version", "")).startswith(("2.", "3.", "4.")):
            _generator_1_is_serial(args)
        else:
            kw = _where_jobs_run(args)
        root = generate_dataset(args.out, config, **kw)
    if splits != ALL_SPLITS:  # the edition pins the whole data: no manifest to compare
        sys.stdout.write(secret_test_split_note(ed) + "\n")
        return 0
    sha = manifest_sha256(root)
    sys.stdout.write(f"wrote the data of edition {ed.name} to {root}\nmanifest sha256 {sha}\n")
    expected = pin.expected_manifest_sha256
    if expected and sha != expected:
        sys.stdout.write(f"WARNING: the edition expects {expected}: this machine generated other "
                         "data, whose scores are not comparable (score with --allow-other-data; "
                         "see docs/synthetic-data.md, Reproducibility)\n")
        return 0 if args.allow_other_data else 1
    if expected:
        sys.stdout.write("matches the edition's expected manifest\n")
    return 0


def _where_jobs_run(args: argparse.Namespace) -> dict:
    """``executor=`` (``--executor``/``--scheduler``) or ``workers=`` of a generator's jobs."""
    if args.executor or args.scheduler:
        return {"executor": executor_from_args(args, default_workers=1)}
    return {"workers": args.workers or 1}


def _designed_garments(args: argparse.Namespace, ed, config) -> int:
    """``synth --edition E --designed-garments``: the edition's garments as designed."""
    if config is None or not str(config.version).startswith("4."):
        raise InputError(f"--designed-garments: edition {ed.name} is not made by generator 4 "
                         "(a ...-v5 retargeting edition is)")
    # start-up: the stage loads when the command runs
    from dressmeup.data.synth.designed4 import DESIGNED_JSON, write_designed

    root = write_designed(args.out, config, **_where_jobs_run(args))
    sys.stdout.write(f"wrote the garments as designed of edition {ed.name} "
                     f"({', '.join(config.splits)}) to {root} ({DESIGNED_JSON})\n")
    return 0


def _probe_machine(ed) -> None:
    """Refuse (one line) to generate an edition whose pinned data this machine would not
    reproduce (:func:`dressmeup.bench.machine.machine_differs`), before anything is written."""
    # start-up: the probe loads the generator only when the command runs
    from dressmeup.bench.machine import machine_differs

    why, probe = machine_differs(ed)
    if why:
        raise InputError(why)
    if probe is not None:
        sys.stdout.write(f"this machine computes the edition's probe sample {probe.sample} as "
                         f"pinned ({probe.seconds:.0f} s): generating\n")


def _synth(args: argparse.Namespace) -> int:
    # start-up: the stage loads when the command runs
    from dressmeup.data.synth import generate_dataset

    if args.edition:
        return _synth_edition(args)
    for flag, given in (("--allow-other-data", args.allow_other_data),
                        ("--designed-garments", args.designed_garments)):
        if given:
            raise InputError(f"{flag} goes with --edition (data the edition pins)")
    if args.secret:
        raise InputError("--secret goes with --edition (the secret of the edition's test split)")
    _generator_1_is_serial(args)
    SAMPLES.check(args.subjects * args.garments * args.poses,
                  "--subjects x --garments x --poses", "samples to generate")
    if args.edge_length is not None:
        MESH_FACES.check(round(2.31 * _GARMENT_AREA_M2 / args.edge_length ** 2),
                         f"--edge-length {args.edge_length:g}",
                         f"faces of a garment of up to {_GARMENT_AREA_M2:g} m^2")
    kw = {}
    if args.edge_length is not None:
        kw["edge_length"] = args.edge_length
    root = generate_dataset(args.out, subjects=args.subjects, garments=args.garments,
                            poses=args.poses, seed=args.seed, body_model=args.body_model,
                            registration_noise=args.registration_noise,
                            write_scan=not args.no_scan, **kw)
    # start-up: the stage loads when the command runs
    from dressmeup.data.dataset import Dataset

    ds = Dataset(root)
    info = ds.info
    sys.stdout.write(f"wrote {len(ds)} samples ({info.get('n_garments')} garments, "
                     f"{info.get('n_subjects')} subjects) to {root}\n")
    rep = info.get("report", {})
    if rep:
        sys.stdout.write(f"skinning vs draped ground truth: mean {rep.get('skinning_mean_mm', 0):.1f} mm "
                         f"(max {rep.get('skinning_max_mm', 0):.1f} mm); "
                         f"time {info.get('timings', {}).get('last_run_s', 0):.1f} s\n")
    return 0


def _validate(args: argparse.Namespace) -> int:
    # start-up: the stage loads when the command runs
    from dressmeup.data.validate import validate_dataset

    rep = validate_dataset(args.root, check_meshes=not args.no_meshes,
                           check_hashes=not args.no_hashes)
    sys.stdout.write(rep.format() + "\n")
    return 0 if rep.ok else 1


def _import(args: argparse.Namespace) -> int:
    # start-up: the stage loads when the command runs
    from dressmeup.data.importing import import_dataset

    frames = None
    if args.frames:
        frames = [f.strip() for f in args.frames.split(",") if f.strip()]
        if args.kind == "cloth3d":
            try:
                frames = [int(f) for f in frames]
            except ValueError:
                raise InputError(f"--frames: CLOTH3D frames are integers, got {args.frames!r}") from None
    kw = {"frames": frames, "stride": args.stride, "smplx": args.smplx, "gender": args.gender,
          "convention": args.convention, "smpl_model_path": args.smpl_model}
    res = import_dataset(args.kind, args.root, args.out, split=args.split, seed=args.seed,
                         with_body=not args.no_body, **kw)
    sys.stdout.write(res.summary + "\n")
    sys.stdout.write(f"wrote {res.written} samples ({res.resumed} already there) to {res.root}\n")
    if args.pictures > 0:
        # start-up: the stage loads when the command runs
        from dressmeup.data.dataset import Dataset
        from dressmeup.viz.overlay import render_sample_overlay

        ds = Dataset(res.root)
        pics = Path(res.root) / "pictures"
        for sid in res.sample_ids[: args.pictures]:
            note = render_sample_overlay(ds[sid], pics / f"{sid}.png", args.smpl_model)
            sys.stdout.write(f"picture {pics / (sid + '.png')}: {note}\n")
    return 0
