"""Editions a server scores: registered with their private part, checked against the
edition's pin first."""

from __future__ import annotations

from pathlib import Path

from sqlalchemy import select
from sqlalchemy.orm import Session

from dressmeup.bench.archives.archive import LOCAL_INDEX, load_pins, verify_folder
from dressmeup.bench.edition import Edition, load_edition
from dressmeup.bench.tasks import get_task
from dressmeup.bench.tasks.common import other_data_reason
from dressmeup.data.parts import part_of
from dressmeup.errors import InputError
from dressmeup.server.db import EditionRow


def check_private_part(edition: Edition, root: Path) -> list[str]:
    """Problems of ``root`` as the private part (or full data) of ``edition``: the pin
    (generator record or manifest), the expected manifest, the shipped pins of the private
    part, and the files against the index a fetch left."""
    if not root.is_dir():
        return [f"{root}: not a folder"]
    part = part_of(root)
    if part == "public":
        return [f"{root} is the public part of the edition: the server needs the private "
                "part (the withheld answers), e.g. fetched with 'dressmeup edition fetch "
                f"{edition.name} --part private'"]
    info, problems = get_task(edition.task).dataset_problems(edition, root)
    other = other_data_reason(edition, info, root)
    if other:
        problems.append(other)
    pins = load_pins(edition)
    want = ((pins or {}).get("private") or {}).get("manifest_sha256")
    if want and part == "private" and info.get("manifest_sha256") != want:
        problems.append(f"{root}: manifest {str(info.get('manifest_sha256'))[:12]}... is not "
                        f"the private part edition {edition.name} pins ({want[:12]}...)")
    if (root / LOCAL_INDEX).is_file():
        problems += verify_folder(root, edition)
    return problems


def add_edition(session: Session, name: str, private: str | Path) -> EditionRow:
    """Register an edition with its private part (replacing an earlier registration).

    Raises
    ------
    InputError
        Unknown edition, or a private part that does not match its pin (every problem).
    """
    ed = load_edition(name)
    root = Path(private).resolve()
    problems = check_private_part(ed, root)
    if problems:
        raise InputError(f"{root} is not the private part of {ed.name}:\n  - "
                         + "\n  - ".join(problems))
    row = session.get(EditionRow, ed.name)
    if row is None:
        row = EditionRow(name=ed.name, edition_hash=ed.hash, private_root=str(root))
        session.add(row)
    else:
        row.edition_hash, row.private_root = ed.hash, str(root)
    session.commit()
    return row


def registered(session: Session) -> list[EditionRow]:
    """Every registered edition, by name."""
    return list(session.scalars(select(EditionRow).order_by(EditionRow.name)))
