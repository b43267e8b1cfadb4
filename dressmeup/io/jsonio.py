"""Reading JSON files the toolkit did not write itself, checked against a JSON Schema.

Every JSON a user can hand the toolkit (``dataset.json``, ``submission.json``, result
``summary.json``, ``session.json``, keypoint files) is read with :func:`read_json`, which
refuses a file that is not UTF-8, not JSON, or does not fit the file's schema
(``dressmeup/io/schemas/<name>.schema.json``, JSON Schema 2020-12, checked with
``jsonschema``) with an :class:`~dressmeup.errors.InputError` naming the file and the field.
"""

from __future__ import annotations

import functools
import json
import os
import re
from pathlib import Path
from typing import Any

import jsonschema

from dressmeup.errors import InputError

SCHEMA_DIR = Path(__file__).resolve().parent / "schemas"
#: Refuse JSON files larger than this before reading them (metadata files are small).
MAX_JSON_BYTES = 64 << 20


@functools.cache
def load_schema(name: str) -> dict[str, Any]:
    """The schema ``name`` (e.g. ``"dataset"``) shipped in ``dressmeup/io/schemas``."""
    path = SCHEMA_DIR / f"{name}.schema.json"
    if not path.is_file():
        raise KeyError(f"no JSON schema named {name!r} in {SCHEMA_DIR}")
    return json.loads(path.read_text(encoding="utf-8"))


def _field(path) -> str:
    parts = [f"[{p}]" if isinstance(p, int) else f".{p}" for p in path]
    return ("".join(parts).lstrip(".")) or "(top level)"


def schema_problems(data: Any, schema: str, source: str = "JSON") -> list[str]:
    """One message per place where ``data`` does not fit schema ``schema`` (empty: fits)."""

    validator = jsonschema.Draft202012Validator(load_schema(schema))
    errors = sorted(validator.iter_errors(data), key=lambda e: (list(map(str, e.path)),
                                                                 e.message))
    out = []
    for e in errors:
        path = list(e.absolute_path)
        msg = e.message
        m = re.match(r"^'(.+)' is a required property$", msg)
        if e.validator == "required" and m:
            path.append(m.group(1))
            msg = "required but missing"
        out.append(f"{source}: field {_field(path)}: {msg}")
    return out


def validate_json(data: Any, schema: str, source: str = "JSON") -> Any:
    """Return ``data`` when it fits schema ``schema``; else raise naming every field.

    Raises
    ------
    InputError
    """
    problems = schema_problems(data, schema, source)
    if problems:
        shown = problems[:10] + ([f"... and {len(problems) - 10} more"]
                                 if len(problems) > 10 else [])
        raise InputError("\n  ".join(shown) if len(shown) == 1
                         else f"{source} does not fit its format:\n  " + "\n  ".join(shown))
    return data


def parse_json_file(path: str | os.PathLike, max_bytes: int = MAX_JSON_BYTES) -> Any:
    """Parse a JSON file; errors name the file (and line/column of a syntax error).

    Raises
    ------
    FileNotFoundError
        When the file does not exist.
    InputError
        Not a regular file, larger than ``max_bytes``, not UTF-8, or not JSON.
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(2, "No such file or directory", str(path))
    if not path.is_file():
        raise InputError(f"{path}: not a regular file (expected a JSON file)")
    size = path.stat().st_size
    if size > max_bytes:
        raise InputError(f"{path}: {size} bytes is too large for a JSON metadata file "
                         f"(limit {max_bytes})")
    raw = path.read_bytes()
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InputError(f"{path}: not UTF-8 text (byte {exc.start}); save it as UTF-8") from exc
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(f"{path}: not valid JSON (line {exc.lineno}, column {exc.colno}: "
                         f"{exc.msg})") from exc
    except RecursionError as exc:
        raise InputError(f"{path}: JSON nested too deeply") from exc


def read_json(path: str | os.PathLike, schema: str | None = None) -> Any:
    """Parse a JSON file and check it against schema ``schema`` (when given).

    Raises
    ------
    FileNotFoundError, InputError
        See :func:`parse_json_file` and :func:`validate_json`.
    """
    data = parse_json_file(path)
    if schema is not None:
        validate_json(data, schema, str(path))
    return data
