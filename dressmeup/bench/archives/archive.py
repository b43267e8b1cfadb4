"""Benchmark data as verified archives: pack a part, fetch it (HTTP(S) or a path, resumable),
verify a folder.

An archive is a gzip-compressed tar of one part (:mod:`dressmeup.bench.parts`) written
deterministically (sorted members, mtime 0, owner 0, mode 0644) beside its **index**
``<edition>-<part>.index.json``: every file's relative path, sha256 and size, the sha256 of
that list (:func:`index_sha256`, independent of the JSON's formatting) and the archive's own
sha256 and size. An edition pins its parts by these figures in
``dressmeup/bench/editions/parts/<edition>.json`` (:func:`load_pins`).

Fetching checks the index against the pin, downloads the archive (resuming a partial
download with an HTTP range request), checks its sha256 before anything is unpacked, then
unpacks member by member: only regular files named in the index with their size, no path
outside the target, no links, and each file's sha256 checked as it is written; the folder is
renamed into place only when complete. Bounds (:mod:`dressmeup.limits`): an index is a JSON
file (``json_bytes``) of at most ``archive_members`` files; what is unpacked is exactly what
the index lists, and must fit on the disk before anything is downloaded.
"""

from __future__ import annotations

import gzip
import hashlib
import json
import os
import shutil
import tarfile
from dataclasses import dataclass
from importlib import resources
from pathlib import Path, PurePosixPath
from typing import Any

from dressmeup.bench.archives.transfer import (
    blocks,
    copy_resumable,
    download,
    is_url,
    join_source,
    read_small,
)
from dressmeup.bench.edition import Edition, load_edition
from dressmeup.data import layout
from dressmeup.data.parts import part_of, part_record
from dressmeup.errors import InputError
from dressmeup.io.atomic import atomic_dir, atomic_path, atomic_write_text
from dressmeup.io.hashing import sha256_file
from dressmeup.io.jsonio import parse_json_bytes
from dressmeup.limits import ARCHIVE_MEMBERS, JSON_BYTES
from dressmeup.progress import progress

INDEX_FORMAT = "dressmeup-archive-index/1"
PINS_FORMAT = "dressmeup-edition-parts/1"
#: the hidden copy of the index a fetched folder keeps (``edition verify`` reads it)
LOCAL_INDEX = ".dressmeup-index.json"


@dataclass(frozen=True)
class Entry:
    """One file of a part: relative POSIX path, sha256 (hex), size in bytes."""

    path: str
    sha256: str
    size: int


def scan_folder(root: str | os.PathLike) -> list[Entry]:
    """Every regular file under ``root`` (hidden names skipped), sorted by path.

    Raises
    ------
    InputError
        A symbolic link or a special file (an archive carries regular files only).
    """
    root = Path(root)
    out = []
    for dirpath, dirnames, filenames in os.walk(root):
        dirnames[:] = sorted(d for d in dirnames if not d.startswith("."))
        for name in filenames:
            if name.startswith("."):
                continue
            p = Path(dirpath) / name
            if p.is_symlink() or not p.is_file():
                raise InputError(f"{p}: not a regular file (links and special files cannot "
                                 "be archived)")
            out.append(Entry(p.relative_to(root).as_posix(), sha256_file(p), p.stat().st_size))
    return sorted(out, key=lambda e: e.path)


def index_sha256(entries: list[Entry]) -> str:
    """sha256 of the lines ``path<TAB>sha256<TAB>size`` of the entries sorted by path."""
    h = hashlib.sha256()
    for e in sorted(entries, key=lambda e: e.path):
        h.update(f"{e.path}\t{e.sha256}\t{e.size}\n".encode())
    return h.hexdigest()


def pack_part(root: str | os.PathLike, out_dir: str | os.PathLike, edition: Edition
              ) -> dict[str, Any]:
    """Pack the part at ``root`` into ``out_dir/<edition>-<part>.tar.gz`` and its index.

    Returns
    -------
    The index (also written to ``out_dir/<edition>-<part>.index.json``).
    """
    root, out_dir = Path(root), Path(out_dir)
    part = part_of(root)
    entries = scan_folder(root)
    if not entries:
        raise InputError(f"{root}: nothing to pack")
    out_dir.mkdir(parents=True, exist_ok=True)
    name = f"{edition.name}-{part}.tar.gz"
    archive = out_dir / name
    with atomic_path(archive) as tmp:
        with open(tmp, "wb") as raw, \
                gzip.GzipFile(filename="", mode="wb", fileobj=raw, mtime=0,
                              compresslevel=6) as gz, \
                tarfile.open(fileobj=gz, mode="w", format=tarfile.PAX_FORMAT) as tar:
            for e in progress(entries, desc=f"packing {name}"):
                info = tarfile.TarInfo(e.path)
                info.size, info.mtime, info.mode = e.size, 0, 0o644
                info.uid = info.gid = 0
                info.uname = info.gname = ""
                with open(root / e.path, "rb") as fh:
                    tar.addfile(info, fh)
    manifest = root / layout.MANIFEST
    index = {
        "format": INDEX_FORMAT, "edition": edition.name, "edition_hash": edition.hash,
        "part": part, "index_sha256": index_sha256(entries),
        "manifest_sha256": sha256_file(manifest) if manifest.is_file() else None,
        "n_files": len(entries), "bytes": sum(e.size for e in entries),
        "archive": {"name": name, "sha256": sha256_file(archive),
                    "bytes": archive.stat().st_size},
        "files": [[e.path, e.sha256, e.size] for e in entries],
    }
    atomic_write_text(out_dir / f"{edition.name}-{part}.index.json",
                      json.dumps(index, indent=0) + "\n")
    return index


def pins_of(indexes: list[dict[str, Any]]) -> dict[str, Any]:
    """The pins file of an edition from the indexes of its packed parts."""
    out: dict[str, Any] = {"format": PINS_FORMAT}
    for idx in indexes:
        out["edition"], out["edition_hash"] = idx["edition"], idx["edition_hash"]
        out[idx["part"]] = {k: idx[k] for k in ("index_sha256", "manifest_sha256", "n_files",
                                                "bytes", "archive")}
    return out


def load_pins(edition: str | Edition) -> dict[str, Any] | None:
    """The shipped pins of an edition's parts (None when it has none)."""
    ed = load_edition(edition)
    res = resources.files("dressmeup.bench") / "editions" / "parts" / f"{ed.name}.json"
    if not res.is_file():
        return None
    pins = json.loads(res.read_text(encoding="utf-8"))
    if pins.get("edition_hash") != ed.hash:
        raise InputError(f"the shipped pins of {ed.name}'s parts were made for another "
                         "version of the edition (edition hash differs)")
    return pins


# --------------------------------------------------------------------------------- fetch
def read_index(data: bytes, where: str) -> tuple[dict[str, Any], list[Entry]]:
    """Parse and check an index (its entries re-hashed against ``index_sha256``)."""
    index = parse_json_bytes(data, where)
    try:
        ARCHIVE_MEMBERS.check(len(index["files"]), where, "files listed")
        entries = [Entry(str(p), str(s), int(n)) for p, s, n in index["files"]]
        archive = index["archive"]
        _ = (str(archive["name"]), str(archive["sha256"]), int(archive["bytes"]))
    except InputError:
        raise
    except (ValueError, KeyError, TypeError) as exc:
        raise InputError(f"{where}: not an archive index ({exc})") from exc
    if index.get("format") != INDEX_FORMAT:
        raise InputError(f"{where}: index format {index.get('format')!r}, this toolkit reads "
                         f"{INDEX_FORMAT!r}")
    if index_sha256(entries) != index.get("index_sha256"):
        raise InputError(f"{where}: the file list does not match its index_sha256 (damaged)")
    for e in entries:
        _safe_member(e.path, where)
    return index, entries


def _safe_member(name: str, where: str) -> PurePosixPath:
    p = PurePosixPath(name)
    if not name or p.is_absolute() or ".." in p.parts or name.startswith(("/", "\\")) \
            or "\\" in name or any(part.startswith(".") for part in p.parts):
        raise InputError(f"{where}: member {name!r} would leave the target folder or is "
                         "hidden; refused")
    return p


def fetch(edition: str | Edition, source: str, out: str | os.PathLike,
          part: str = "public", require_pin: bool = True) -> Path:
    """Fetch one part of an edition's data into ``out`` and verify it.

    Parameters
    ----------
    edition : the edition.
    source : a folder or http(s) base URL holding ``<edition>-<part>.index.json`` and the
        archive it names.
    out : the data folder to create (must not exist, or be empty).
    part : ``public`` (what participants need) or ``private`` (maintainers, servers).
    require_pin : refuse an edition without shipped pins (False: trust the index, for
        editions of your own).

    Returns
    -------
    ``out``.

    Raises
    ------
    InputError
        Index or archive not as pinned, download failure, an unsafe or unexpected member, a
        file whose sha256 differs; nothing is left in ``out`` then.
    """
    ed = load_edition(edition)
    if part not in ("public", "private"):
        raise InputError(f"part: expected 'public' or 'private', got {part!r}")
    out = Path(out)
    if out.exists() and any(p for p in out.iterdir() if not p.name.startswith(".")):
        raise InputError(f"{out} exists and is not empty: fetch into a new folder (or check "
                         "it with 'dressmeup edition verify')")
    pins = load_pins(ed)
    pin = (pins or {}).get(part)
    if pin is None and require_pin:
        raise InputError(f"edition {ed.name} ships no pins for its {part} part: nothing to "
                         "verify a download against")
    where = join_source(source, f"{ed.name}-{part}.index.json")
    index, entries = read_index(read_small(where), where)
    if index.get("edition") != ed.name or index.get("part") != part:
        raise InputError(f"{where}: an index of {index.get('edition')}/{index.get('part')}, "
                         f"not of {ed.name}/{part}")
    if pin is not None and (index["index_sha256"] != pin["index_sha256"]
                            or index["archive"]["sha256"] != pin["archive"]["sha256"]):
        raise InputError(f"{where}: not the {part} part edition {ed.name} pins (index or "
                         "archive sha256 differs)")
    arc = index["archive"]
    out.mkdir(parents=True, exist_ok=True)
    need = int(arc["bytes"]) + sum(e.size for e in entries)
    free = shutil.disk_usage(out).free
    if need > free:
        raise InputError(f"{ed.name} {part}: needs {need / 1e9:.1f} GB (archive and files), "
                         f"{out} has {free / 1e9:.1f} GB free")
    partial = out / f".{arc['name']}.part"
    src = join_source(source, arc["name"])
    if is_url(source):
        download(src, partial, int(arc["bytes"]))
    else:
        copy_resumable(Path(src), partial)
    got, n_got = sha256_file(partial), partial.stat().st_size
    if got != arc["sha256"] or n_got != int(arc["bytes"]):
        partial.unlink()
        raise InputError(f"{src}: sha256 {got[:16]}... of {n_got} bytes, the index says "
                         f"{arc['sha256'][:16]}... of {arc['bytes']} bytes: the download is "
                         "corrupted (removed); fetch again")
    _unpack(partial, out, entries, where)
    partial.unlink()
    atomic_write_text(out / LOCAL_INDEX, json.dumps(index, indent=0) + "\n")
    return out


def _unpack(archive: Path, out: Path, entries: list[Entry], where: str) -> None:
    """Unpack ``archive`` into ``out`` checking every member against ``entries``."""
    expected = {e.path: e for e in entries}
    seen: set[str] = set()
    staging = out.parent / f".{out.name}.unpack"
    if staging.exists():
        shutil.rmtree(staging)
    with atomic_dir(staging) as tmp, tarfile.open(archive, mode="r:gz") as tar:
        for n, member in enumerate(tar):
            if n >= len(expected):
                raise InputError(f"{archive.name}: more members than its index lists")
            name = member.name
            _safe_member(name, archive.name)
            if not member.isreg():
                raise InputError(f"{archive.name}: member {name!r} is not a regular file "
                                 "(links, devices and folders are refused)")
            want = expected.get(name)
            if want is None or name in seen:
                raise InputError(f"{archive.name}: member {name!r} is not in the index "
                                 "(or twice)")
            if member.size != want.size:
                raise InputError(f"{archive.name}: member {name!r} has {member.size} bytes, "
                                 f"the index says {want.size}")
            seen.add(name)
            dest = tmp / name
            dest.parent.mkdir(parents=True, exist_ok=True)
            h = hashlib.sha256()
            src = tar.extractfile(member)
            with open(dest, "wb") as fh:
                for block in blocks(src):
                    h.update(block)
                    fh.write(block)
            if h.hexdigest() != want.sha256:
                raise InputError(f"{archive.name}: member {name!r} differs from the index "
                                 "(sha256)")
        missing = sorted(set(expected) - seen)
        if missing:
            raise InputError(f"{archive.name}: {len(missing)} file(s) of the index are missing, "
                             f"e.g. {missing[0]}")
    for p in staging.iterdir():
        os.replace(p, out / p.name)
    staging.rmdir()


# -------------------------------------------------------------------------------- verify
def verify_folder(root: str | os.PathLike, edition: str | Edition | None = None
                  ) -> list[str]:
    """Problems of a data folder against its index and the edition's pins ([]: verified).

    The folder's part and edition come from its ``dataset.json`` (``edition`` overrides the
    latter). With the index a fetch left (:data:`LOCAL_INDEX`) every file is named that is
    missing, extra or different; without it the folder's file list is hashed and compared
    with the pin.
    """
    root = Path(root)
    if not root.is_dir():
        return [f"{root}: not a folder"]
    rec = part_record(root)
    part = part_of(root)
    name = edition if edition is not None else rec.get("edition")
    if name is None:
        return [f"{root}: dataset.json names no edition (give one)"]
    ed = load_edition(name)
    entries = {e.path: e for e in scan_folder(root)}
    problems = []
    local = root / LOCAL_INDEX
    if local.is_file():
        JSON_BYTES.check(local.stat().st_size, str(local), "index size")
        index, listed = read_index(local.read_bytes(), str(local))
        want = {e.path: e for e in listed}
        for p in sorted(set(want) - set(entries)):
            problems.append(f"{p}: missing")
        for p in sorted(set(entries) - set(want)):
            problems.append(f"{p}: not in the index (an extra file)")
        for p in sorted(set(want) & set(entries)):
            if want[p] != entries[p]:
                problems.append(f"{p}: differs from the index (sha256 or size)")
        target = index["index_sha256"]
    else:
        target = None
    pins = load_pins(ed)
    pin = (pins or {}).get(part)
    got = index_sha256(list(entries.values()))
    if pin is not None and got != pin["index_sha256"]:
        problems.append(f"the {part} part of {ed.name} is pinned as {pin['index_sha256'][:16]}..., "
                        f"this folder hashes to {got[:16]}...")
    if pin is None and target is not None and got != target:
        problems.append(f"the folder hashes to {got[:16]}..., its index says {target[:16]}...")
    if pin is None and target is None:
        problems.append(f"nothing to verify against: edition {ed.name} pins no {part} part "
                        "and the folder has no index")
    return problems
