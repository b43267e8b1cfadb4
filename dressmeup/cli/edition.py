"""``dressmeup edition``: editions and their data (create, pin, secret, export, pack, fetch,
verify)."""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

from dressmeup.cli.checks import integer, new_output, output_file
from dressmeup.errors import InputError
from dressmeup.io.atomic import atomic_write_text
from dressmeup.io.outlock import output_lock


def register(subparsers: argparse._SubParsersAction) -> None:
    """Register the ``edition`` subcommands."""
    p = subparsers.add_parser(
        "edition", help="an edition's data: create, pin, secret, export, pack, fetch, verify",
        description="Editions and their data. 'create' writes an edition for a dataset you "
                    "built (pinned by its manifest sha256); 'pin' writes into a generated "
                    "edition the manifest sha256 of its generated data; 'secret' makes the "
                    "secret that "
                    "seeds a generated edition's test split; 'export' splits an edition's data "
                    "into the public part (what a method receives) and the private part "
                    "(the withheld answers scoring needs); 'pack' writes the parts as "
                    "checksummed archives with an index; 'fetch' downloads and verifies a "
                    "part; 'verify' re-checks a data folder (docs/benchmark.md, 'Data').")
    esub = p.add_subparsers(dest="edition_command", metavar="ACTION", required=True)
    _add_create(esub)
    _add_pin(esub)
    _add_secret(esub)
    _add_export(esub)
    _add_pack(esub)
    _add_fetch(esub)
    _add_verify(esub)


def _add_create(esub: argparse._SubParsersAction) -> None:
    """``edition create``: an edition pinned by a dataset's manifest sha256."""
    c = esub.add_parser(
        "create", help="write an edition pinned by the manifest sha256 of a dataset",
        description="Write an edition JSON pinned by the sha256 of DATA/manifest.parquet "
                    "(scoring refuses any other data), with the task's default options. "
                    "Check it scores your data with 'dressmeup validate-submission'.")
    c.add_argument("--data", "-d", required=True, help="dataset root (dataset.json + "
                   "manifest.parquet)")
    c.add_argument("--task", "-t", required=True,
                   choices=("retarget", "uvparam", "fusion", "registration", "correspondence"))
    c.add_argument("--name", "-n", required=True, help="edition name (letters, digits, . - _)")
    c.add_argument("--split", default="test", help="manifest split scored (default test)")
    c.add_argument("--metrics", default=None,
                   help="comma-separated metrics in table order (default: all of the task)")
    c.add_argument("--primary-metric", default=None,
                   help="metric leaderboards sort by (default: the first)")
    c.add_argument("--version", type=integer(1), default=1, help="edition version (default 1)")
    c.add_argument("--description", default=None, help="free text (default: generated)")
    c.add_argument("--out", "-o", default=None, type=output_file,
                   help="edition file (default: NAME.json)")
    c.add_argument("--overwrite", action="store_true", help="replace an existing file")
    c.set_defaults(func=_edition_create)


def _add_pin(esub: argparse._SubParsersAction) -> None:
    """``edition pin``: a generated edition pinned to the manifest of its data."""
    c = esub.add_parser(
        "pin", help="write into a generated edition the manifest sha256 of its data",
        description="Check that DATA is a finished, intact generation of the edition (its "
                    "generator version, parameters and seed, every split, the test split "
                    "seeded by the edition's secret), then write the sha256 of "
                    "DATA/manifest.parquet into the edition file as "
                    "dataset.expected_manifest_sha256 (written as 2-space-indented JSON, as the "
                    "shipped editions are: for them only that line changes). Scoring then "
                    "refuses other data unless --allow-other-data. Generator-4 editions "
                    "(...-v5).")
    c.add_argument("edition", metavar="EDITION_FILE", help="the edition JSON file to pin "
                   "(a shipped one: dressmeup/bench/editions/NAME.json in a checkout)")
    c.add_argument("--data", "-d", required=True,
                   help="the data 'dressmeup synth OUT --edition EDITION_FILE [--secret FILE]' "
                        "wrote")
    c.add_argument("--replace", action="store_true",
                   help="replace a different pin the file holds (its results are then of "
                        "another edition)")
    c.set_defaults(func=_pin)


def _add_secret(esub: argparse._SubParsersAction) -> None:
    """``edition secret``: a new secret for a secret test split."""
    c = esub.add_parser(
        "secret", help="write a new secret that seeds a generated edition's test split",
        description="Write 32 random bytes as 64 hex characters to a new file, readable by "
                    "its owner only (0600; an existing file is never overwritten), and print "
                    "its commitment (sha256), which the edition publishes as "
                    "dataset.test_split.commitment. Keep the file: whoever holds it generates "
                    "the test split (dressmeup synth --edition E --secret FILE); publishing it "
                    "reveals the test split (docs/benchmark.md, 'Secret test splits').")
    c.add_argument("--out", "-o", required=True, type=output_file, help="new secret file")
    c.set_defaults(func=_secret)


def _add_export(esub: argparse._SubParsersAction) -> None:
    """``edition export``: an edition's data split into its public and private parts."""
    c = esub.add_parser(
        "export", help="split an edition's full data into its public and private parts",
        description="Write the public part (train/val complete; of the scored split only what "
                    "a method receives) and/or the private part (everything scoring needs: "
                    "the full manifest and every file of the scored split) of an edition's "
                    "full data. Checks the data against the edition's pin first.")
    c.add_argument("name", help="edition name or JSON file")
    c.add_argument("--data", "-d", required=True, help="the edition's full data")
    c.add_argument("--public", default=None, type=new_output,
                   help="new folder for the public part")
    c.add_argument("--private", default=None, type=new_output,
                   help="new folder for the private part")
    c.add_argument("--allow-other-data", action="store_true",
                   help="export data whose manifest differs from the edition's pin")
    c.set_defaults(func=_export, locks=("public", "private"))


def _add_pack(esub: argparse._SubParsersAction) -> None:
    """``edition pack``: parts as checksummed archives with their indexes."""
    c = esub.add_parser(
        "pack", help="write a part (or both) as a checksummed archive with its index",
        description="Pack the data into NAME-<part>.tar.gz and NAME-<part>.index.json in "
                    "--out (per-file sha256 and size, archive sha256). --data is a part, or "
                    "the full data (both parts are exported first). With --pins, also write "
                    "the pins file an edition ships (dressmeup/bench/editions/parts/NAME.json).")
    c.add_argument("name", help="edition name or JSON file")
    c.add_argument("--data", "-d", required=True, help="the full data or one part")
    c.add_argument("--out", "-o", required=True, type=new_output,
                   help="folder for archives and indexes")
    c.add_argument("--pins", default=None, type=output_file,
                   help="write the edition's pins file here")
    c.set_defaults(func=_pack, locks=("out", "pins"))


def _add_fetch(esub: argparse._SubParsersAction) -> None:
    """``edition fetch``: download a part and verify it."""
    c = esub.add_parser(
        "fetch", help="download a part of an edition's data and verify it",
        description="Download NAME-<part>.index.json and its archive from a folder or an "
                    "http(s) base URL, check both against the edition's pins, resume an "
                    "interrupted download, check the archive's sha256 before unpacking, "
                    "unpack safely (only indexed regular files, nothing outside --out) and "
                    "verify every file.")
    c.add_argument("name", help="edition name")
    c.add_argument("--from", dest="source", required=True,
                   help="folder or http(s) URL holding the archives")
    c.add_argument("--out", "-o", required=True, type=new_output, help="new data folder")
    c.add_argument("--part", choices=("public", "private"), default="public")
    c.add_argument("--unpinned", action="store_true",
                   help="accept an edition that ships no pins (trust the index)")
    c.set_defaults(func=_fetch, locks=("out",))


def _add_verify(esub: argparse._SubParsersAction) -> None:
    """``edition verify``: re-check a data folder."""
    c = esub.add_parser(
        "verify", help="re-check a data folder against its index and the edition's pins",
        description="Hash every file of ROOT and compare with the index a fetch left and the "
                    "edition's pins; exit 1 and name every missing, extra or changed file.")
    c.add_argument("root", help="data folder (a part)")
    c.add_argument("--edition", "-e", default=None,
                   help="edition (default: the one ROOT's dataset.json names)")
    c.set_defaults(func=_verify)


def _edition_create(args: argparse.Namespace) -> int:
    # start-up: the stage loads when the command runs
    from dressmeup.bench.edition_create import create_edition

    out = Path(args.out or f"{args.name}.json")
    with output_lock(out, "--out"):
        if out.exists() and not args.overwrite:
            raise InputError(f"{out} already exists: choose another --out or pass --overwrite")
        metrics = [m.strip() for m in args.metrics.split(",") if m.strip()] \
            if args.metrics else None
        ed = create_edition(args.data, args.task, args.name, split=args.split,
                            metrics=metrics, primary_metric=args.primary_metric,
                            version=args.version, description=args.description)
        ed.save(out)
    sys.stdout.write(f"edition {ed.name} written to {out}\n  dataset manifest sha256 "
                     f"{ed.dataset.manifest_sha256}\n  edition hash {ed.hash}\n"
                     f"score with: dressmeup score SUBMISSION --edition {out} --data "
                     f"{args.data} --out RESULTS\n")
    return 0


def _pin(args: argparse.Namespace) -> int:
    # start-up: the stage loads when the command runs
    from dressmeup.bench.edition_create import pin_expected_manifest

    res = pin_expected_manifest(args.edition, args.data, replace=args.replace)
    if not res.changed:
        sys.stdout.write(f"{res.path} already expects manifest sha256 {res.sha256}; "
                         f"unchanged (edition hash {res.new_hash})\n")
        return 0
    was = f" (was {res.previous})" if res.previous else ""
    sys.stdout.write(f"{res.path}: dataset.expected_manifest_sha256 {res.sha256}{was}\n"
                     f"  edition hash {res.old_hash} -> {res.new_hash}\n")
    return 0


def _secret(args: argparse.Namespace) -> int:
    # start-up: the stage loads when the command runs
    from dressmeup.data.synth.secret import write_new_secret

    com = write_new_secret(args.out)
    sys.stdout.write(f"secret written to {args.out} (mode 0600; keep it, never commit it)\n"
                     f"commitment {com}\n")
    return 0


def _export(args: argparse.Namespace) -> int:
    # start-up: the stage loads when the command runs
    from dressmeup.bench.parts import export_parts, leaks

    if not args.public and not args.private:
        raise InputError("give --public OUT and/or --private OUT")
    res = export_parts(args.name, args.data, args.public, args.private,
                       allow_other_data=args.allow_other_data)
    rep = res.parts
    for part, n, size in (("public", rep.public_files, rep.public_bytes),
                          ("private", rep.private_files, rep.private_bytes)):
        if getattr(args, part):
            sys.stdout.write(f"{part}: {getattr(args, part)} ({n} files, "
                             f"{size / 1e6:.1f} MB)\n")
    sys.stdout.write(f"withheld: {len(rep.withheld)} files of the scored split\n")
    if res.public_answers:
        sys.stdout.write(f"note: {len(res.public_answers)} scored item(s) have their answer in "
                         "the public part (a target is also another pair's source), e.g. "
                         f"{next(iter(res.public_answers))}\n")
    if args.public and args.private:
        found = leaks(args.public, args.private)
        for line in found:
            sys.stdout.write(f"LEAK: {line}\n")
        return 1 if found else 0
    return 0


def _pack(args: argparse.Namespace) -> int:
    # start-up: the stage loads when the command runs
    from dressmeup.bench.archives.archive import pack_part, pins_of
    from dressmeup.bench.edition import load_edition
    from dressmeup.bench.parts import export_parts
    from dressmeup.data.parts import part_of

    ed = load_edition(args.name)
    data = Path(args.data)
    indexes = []
    if part_of(data) == "full" and ed.task != "uvparam":
        Path(args.out).mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryDirectory(dir=args.out, prefix=".export-") as tmp:
            export_parts(ed, data, Path(tmp) / "public", Path(tmp) / "private")
            for part in ("public", "private"):
                indexes.append(pack_part(Path(tmp) / part, args.out, ed))
    else:
        indexes.append(pack_part(data, args.out, ed))
    for idx in indexes:
        a = idx["archive"]
        sys.stdout.write(f"{a['name']}: {a['bytes'] / 1e6:.1f} MB, {idx['n_files']} files, "
                         f"sha256 {a['sha256']}\n")
    if args.pins:
        atomic_write_text(Path(args.pins), json.dumps(pins_of(indexes), indent=2) + "\n")
        sys.stdout.write(f"pins written to {args.pins}\n")
    return 0


def _fetch(args: argparse.Namespace) -> int:
    # start-up: the stage loads when the command runs
    from dressmeup.bench.archives.archive import fetch, verify_folder

    out = fetch(args.name, args.source, args.out, part=args.part,
                require_pin=not args.unpinned)
    problems = verify_folder(out, args.name)
    if problems:
        sys.stdout.write("\n".join(problems) + "\n")
        return 1
    sys.stdout.write(f"{args.name} ({args.part}) fetched to {out} and verified\n")
    return 0


def _verify(args: argparse.Namespace) -> int:
    # start-up: the stage loads when the command runs
    from dressmeup.bench.archives.archive import verify_folder

    problems = verify_folder(args.root, args.edition)
    for line in problems:
        sys.stdout.write(line + "\n")
    if problems:
        return 1
    sys.stdout.write(f"{args.root}: verified\n")
    return 0
