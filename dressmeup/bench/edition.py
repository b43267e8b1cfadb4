"""Benchmark editions: versioned, hashable configs that freeze a benchmark protocol.

An edition is a JSON file (schema ``dressmeup-edition/1``) naming a task, the dataset it is
scored on (a generated dataset pinned by generator, generator version, parameters and seed; a
real one by the sha256 of its manifest), the split, the metrics and their options (surface
sample counts and seed, size limit of a submission file, ...). Reference editions ship in
``dressmeup/bench/editions/`` and are found by name; any other edition is given as a path.

The edition hash is the sha256 of the edition's canonical JSON (keys sorted, no spaces,
defaults filled in, ``description`` left out so that rewording the text does not change the
protocol, and so is a published test-split secret: publishing it changes no protocol). Every
result records it, and leaderboards refuse to mix hashes.

An edition is checked when it is loaded, before any work: every field, and what its options
and pairs would make against the resource policy (:mod:`dressmeup.limits`: surface samples
per mesh, a geodesic matrix, an overlap grid, the rows of the result table); what it asks of
its data (pairs per garment) is checked when the data is opened (the task's ``items``).
"""

from __future__ import annotations

import copy
import hashlib
import json
import os
import re
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

from dressmeup.bench.edition_pin import DatasetPin, parse_pin
from dressmeup.bench.tasks import Task, get_task
from dressmeup.data.synth.secret import commitment, read_secret
from dressmeup.errors import InputError
from dressmeup.io.atomic import atomic_write_text
from dressmeup.io.jsonio import parse_json_file
from dressmeup.limits import ARRAY_BYTES, IMAGE_PIXELS, SURFACE_SAMPLES, TABLE_ROWS, LimitError

SCHEMA = "dressmeup-edition/1"
TASKS = ("retarget", "uvparam", "fusion", "registration", "correspondence")
_NAME_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]*$")
_REQUIRED = ("name", "version", "task", "dataset", "split", "metrics")

#: Options that size what scoring makes: option -> (the limit, the amount an option value
#: asks for, what that amount is). Each is also an integer >= 1.
_OPTION_COSTS = {
    "n_samples": (SURFACE_SAMPLES, lambda n: n, "surface samples per mesh"),
    "max_vertices": (ARRAY_BYTES, lambda n: 8 * n * n,
                     "geodesic distance matrix (max_vertices^2 float64)"),
    "overlap_resolution": (IMAGE_PIXELS, lambda n: n * n,
                           "overlap grid (overlap_resolution^2 cells)"),
    "k": (None, None, "neighbours"),
}


@dataclass(frozen=True)
class PrimaryFigure:
    """The figure an edition's leaderboards rank by.

    Attributes
    ----------
    metric : a metric of the edition.
    track : a track of the edition, or None: the metric over every item.
    """

    metric: str
    track: str | None = None

    @property
    def key(self) -> str:
        """The leaderboard column: ``metric`` or ``metric#track``."""
        return self.metric if self.track is None else f"{self.metric}#{self.track}"


@dataclass(frozen=True)
class Edition:
    """A loaded, validated benchmark edition (see the module docstring).

    Attributes
    ----------
    name : edition name (``synth-retarget-v2``).
    version : integer version of the edition (bumped on any protocol change).
    task : one of :data:`TASKS`.
    dataset : the dataset pin.
    split : the manifest split scored (``test``).
    metrics : metric names, in table order (a subset of the task's metrics).
    options : metric options, task defaults filled in.
    primary : the figure leaderboards rank by (:class:`PrimaryFigure`: a metric, over one
        track or over all items). In the JSON file: ``primary_metric`` and, for a track,
        ``primary: {"metric": m, "track": t}``.
    per_category : metrics shown per category in leaderboards.
    tracks : names of the tracks scored and shown separately (retarget v3: ``re-pose``,
        ``re-shape``, ``cross``); empty for editions without tracks.
    sensitivity : metric -> the ground truth's measured sensitivity in stored units (how far
        it moves when its solver runs longer or starts elsewhere): leaderboards never call a
        smaller difference separated; empty when not measured.
    pairs : retarget pair sampling, ``{"seed": int, "per_track": {track: pairs per source
        garment}}``, optionally ``"categories"`` and ``"sources": {"pose": POSE_ID,
        "subjects": N}`` or ``"sources": "dataset"`` (the sources disjoint from the targets: see
        :func:`dressmeup.bench.tasks.retarget.data.sample_pairs`); empty: every pair of the
        split.
    description : free text (not hashed).
    source : where it was loaded from (not hashed).
    """

    name: str
    version: int
    task: str
    dataset: DatasetPin
    split: str
    metrics: tuple[str, ...]
    options: dict[str, Any]
    primary: PrimaryFigure
    per_category: tuple[str, ...] = ()
    description: str = ""
    source: str = ""
    tracks: tuple[str, ...] = ()
    pairs: dict[str, Any] = field(default_factory=dict)
    sensitivity: dict[str, float] = field(default_factory=dict)

    def to_dict(self, include_description: bool = True) -> dict[str, Any]:
        """Serialise to the JSON structure of the edition file (defaults filled in);
        ``include_description=False`` is the hashed form: no description and no published
        secret (``dataset.test_split.secret``)."""
        d: dict[str, Any] = {
            "schema": SCHEMA,
            "name": self.name,
            "version": self.version,
            "task": self.task,
            "dataset": self.dataset.to_dict(include_secret=include_description),
            "split": self.split,
            "metrics": list(self.metrics),
            "options": copy.deepcopy(self.options),
            "primary_metric": self.primary.metric,
            "per_category": list(self.per_category),
        }
        # optional fields (editions v3): absent from older editions, so their hash is unchanged
        if self.tracks:
            d["tracks"] = list(self.tracks)
        if self.primary.track is not None:
            d["primary"] = {"metric": self.primary.metric, "track": self.primary.track}
        if self.pairs:
            d["pairs"] = copy.deepcopy(self.pairs)
        if self.sensitivity:
            d["sensitivity"] = dict(self.sensitivity)
        if include_description:
            d["description"] = self.description
        return d

    def canonical_json(self) -> str:
        """The canonical JSON that is hashed (sorted keys, compact, no description)."""
        return json.dumps(self.to_dict(include_description=False), sort_keys=True,
                          separators=(",", ":"), ensure_ascii=True, allow_nan=False)

    @property
    def hash(self) -> str:
        """sha256 hex digest of :meth:`canonical_json`."""
        return hashlib.sha256(self.canonical_json().encode("ascii")).hexdigest()

    @property
    def size_limit_bytes(self) -> int:
        """Per-file size limit of a submission, in bytes."""
        return int(float(self.options.get("size_limit_mb", 256)) * 1024 * 1024)

    def save(self, path: str | os.PathLike) -> None:
        """Write the edition as pretty JSON (atomically)."""

        atomic_write_text(path, json.dumps(self.to_dict(), indent=2, sort_keys=False) + "\n")


def list_editions() -> list[str]:
    """Names of the reference editions shipped inside the package, sorted."""
    folder = resources.files("dressmeup.bench") / "editions"
    return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".json"))


def load_edition(name_or_path: str | os.PathLike | Edition) -> Edition:
    """Load an edition by shipped name (``synth-retarget-v2``) or from a JSON file path.

    Parameters
    ----------
    name_or_path : a shipped edition name, a path to an edition JSON file, or an
        :class:`Edition` (returned as is).

    Returns
    -------
    Edition, validated, with the task's default options filled in.

    Raises
    ------
    InputError
        Unknown name (the message lists the shipped editions), unreadable file, invalid JSON
        or any invalid field (every problem is listed).
    """
    if isinstance(name_or_path, Edition):
        return name_or_path
    text_path = str(name_or_path)
    path = Path(text_path)
    if path.suffix == ".json" or path.exists() or os.sep in text_path:
        if not path.is_file():
            raise InputError(f"edition file {path} does not exist")
        # bounded (json_bytes), UTF-8 and JSON checked, errors naming the file
        return edition_from_dict(parse_json_file(path), source=str(path))
    res = resources.files("dressmeup.bench") / "editions" / f"{text_path}.json"
    if not res.is_file():
        raise InputError(f"unknown edition {text_path!r}: shipped editions are "
                         f"{', '.join(list_editions())}; or give a path to an edition "
                         "JSON file")
    source = f"dressmeup:{text_path}"
    raw = res.read_text(encoding="utf-8")
    try:
        data = json.loads(raw)
    except json.JSONDecodeError as exc:
        raise InputError(f"edition {source}: invalid JSON ({exc})") from exc
    return edition_from_dict(data, source=source)


#: the splits a generated edition's data are made of
ALL_SPLITS = ("train", "val", "test")


def edition_secret(edition: Edition, secret_file: str | os.PathLike | None = None
                   ) -> bytes | None:
    """The secret that seeds ``edition``'s test split, when it is known: the one in
    ``secret_file``, else the one the edition publishes, else None (the test split is not
    generated; a participant fetches its public part).

    Call it before any work: a secret that does not match the edition's commitment is
    refused here.

    Raises
    ------
    InputError
        ``secret_file`` is not a secret (:func:`~dressmeup.data.synth.secret.read_secret`),
        does not match the edition's commitment, or is given for an edition whose test split
        is seeded publicly.
    """
    pin = edition.dataset
    com = pin.test_split_commitment if pin is not None else None
    if secret_file is None:
        return pin.published_secret if com else None
    where = edition.source or edition.name
    if com is None:
        raise InputError(f"--secret {secret_file}: edition {edition.name} ({where}) has no "
                         "secret test split (no dataset.test_split: its test split is seeded by "
                         "the public seed); drop --secret")
    secret = read_secret(secret_file)
    if commitment(secret) != com:
        raise InputError(f"secret file {secret_file} is not the secret of edition "
                         f"{edition.name} ({where}): its sha256 differs from the edition's "
                         "dataset.test_split.commitment; check which secret file the edition "
                         "was made with")
    return secret


def splits_to_generate(edition: Edition, secret: bytes | None) -> tuple[str, ...]:
    """The splits of ``edition``'s data that can be generated knowing ``secret``: every one,
    or only train and val when the test split is seeded by a secret not known
    (:func:`edition_secret` gave None)."""
    pin = edition.dataset
    if pin is not None and pin.test_split_commitment and secret is None:
        return ("train", "val")
    return ALL_SPLITS


def secret_test_split_note(edition: Edition) -> str:
    """The one line that says where the test split of ``edition`` comes from when its secret
    is not known (:func:`splits_to_generate` gave train and val only)."""
    return (f"the test split of {edition.name} is seeded by a secret (the edition publishes "
            "its commitment only): generated train and val; fetch the test split's public part "
            f"with `dressmeup edition fetch {edition.name} --from URL --out DIR`")


def edition_from_dict(data: dict[str, Any], source: str = "<dict>") -> Edition:
    """Validate an edition dict and build an :class:`Edition` (defaults filled in).

    Raises
    ------
    InputError
        Listing every invalid or missing field of the edition.
    """

    problems: list[str] = []
    if not isinstance(data, dict):
        raise InputError(f"edition {source}: expected a JSON object, got {type(data).__name__}")
    name, version, task = _parse_identity(data, problems)
    pin = None
    if "dataset" in data:
        pin, pin_problems = parse_pin(data["dataset"])
        problems += pin_problems
    split = data.get("split", "")
    if "split" in data and (not isinstance(split, str) or not split):
        problems.append(f"split must be a non-empty string, got {split!r}")
    metrics, options = _parse_metrics(data, task, problems)
    primary = data.get("primary_metric", metrics[0] if metrics else "")
    if metrics and primary not in metrics:
        problems.append(f"primary_metric {primary!r} is not in metrics {metrics}")
    per_category = data.get("per_category", [primary] if primary else [])
    if not isinstance(per_category, list) or any(m not in metrics for m in per_category):
        problems.append(f"per_category must list metrics of the edition, got {per_category!r}")
        per_category = []
    tracks, primary_track, pairs = _parse_tracks(data, metrics, problems)
    if primary_track is not None and primary_track["metric"] != primary:
        problems.append(f"primary.metric {primary_track['metric']!r} differs from primary_metric "
                        f"{primary!r}: an edition ranks by one figure")
    sensitivity = data.get("sensitivity", {})
    if not isinstance(sensitivity, dict) or any(
            m not in metrics or isinstance(v, bool) or not isinstance(v, (int, float)) or v < 0
            for m, v in sensitivity.items()):
        problems.append(f"sensitivity must map metrics of the edition to numbers >= 0, got "
                        f"{sensitivity!r}")
        sensitivity = {}
    if problems:
        raise InputError(f"edition {source} is invalid:\n  - " + "\n  - ".join(problems))
    return Edition(name=name, version=int(version), task=data.get("task"), dataset=pin,
                   split=split, metrics=tuple(metrics), options=options,
                   primary=PrimaryFigure(primary, primary_track and primary_track["track"]),
                   per_category=tuple(per_category),
                   description=str(data.get("description", "")), source=source,
                   tracks=tracks, pairs=pairs,
                   sensitivity={str(k): float(v) for k, v in sensitivity.items()})


def _parse_identity(data: dict[str, Any], problems: list[str]) -> tuple[Any, Any, Task | None]:
    """Schema, required and unknown fields, ``name``, ``version`` and ``task`` (appends
    problems). Returns the name, the version and the task (None when not a known task)."""
    schema = data.get("schema", SCHEMA)
    if schema != SCHEMA:
        problems.append(f"schema is {schema!r}, this toolkit reads {SCHEMA!r}")
    for key in _REQUIRED:
        if key not in data:
            problems.append(f"missing field {key!r}")
    known = set(_REQUIRED) | {"schema", "options", "primary_metric", "per_category",
                              "description", "tracks", "primary", "pairs", "sensitivity"}
    for key in sorted(set(data) - known):
        problems.append(f"unknown field {key!r}")
    name = data.get("name", "")
    if "name" in data and (not isinstance(name, str) or not _NAME_RE.match(name)):
        problems.append(f"name must use letters, digits, '.', '-', '_', got {name!r}")
    version = data.get("version", 0)
    if "version" in data and (not isinstance(version, int) or isinstance(version, bool)
                              or version < 1):
        problems.append(f"version must be an integer >= 1, got {version!r}")
    task_name = data.get("task")
    task = None
    if "task" in data:
        if task_name not in TASKS:
            problems.append(f"task must be one of {', '.join(TASKS)}, got {task_name!r}")
        else:
            task = get_task(task_name)
    return name, version, task


def _parse_metrics(data: dict[str, Any], task: Task | None,
                   problems: list[str]) -> tuple[list, dict[str, Any]]:
    """``metrics`` (metrics of the task) and ``options`` (the task's defaults, overridden by
    known options; numeric ones must be numbers >= 0); appends problems."""
    metrics = data.get("metrics", [])
    options = dict(task.default_options) if task else {}
    user_options = data.get("options", {})
    if not isinstance(user_options, dict):
        problems.append(f"options must be an object, got {type(user_options).__name__}")
        user_options = {}
    if task is None:
        return metrics, options
    known_metrics = [m.name for m in task.metrics]
    if not isinstance(metrics, list) or not metrics:
        problems.append("metrics must be a non-empty list")
        metrics = []
    for m in metrics:
        if m not in known_metrics:
            problems.append(f"metric {m!r} is not a {task.name} metric "
                            f"({', '.join(known_metrics)})")
    for key in sorted(set(user_options) - set(task.default_options)):
        problems.append(f"unknown option {key!r} for task {task.name} "
                        f"(known: {', '.join(sorted(task.default_options))})")
    for key, value in user_options.items():
        if key in task.default_options:
            default = task.default_options[key]
            if isinstance(default, (int, float)) and not isinstance(default, bool):
                if not isinstance(value, (int, float)) or isinstance(value, bool) \
                        or value < 0:
                    problems.append(f"option {key!r} must be a number >= 0, got {value!r}")
                    continue
            if key in _OPTION_COSTS and not _option_cost_ok(key, value, problems):
                continue
            options[key] = value
    return metrics, options


def _option_cost_ok(key: str, value: Any, problems: list[str]) -> bool:
    """Whether option ``key`` (one of :data:`_OPTION_COSTS`) is an integer >= 1 within its
    resource limit; appends the problem when not."""
    limit, amount, what = _OPTION_COSTS[key]
    if not float(value).is_integer() or value < 1:
        problems.append(f"options.{key} must be an integer >= 1, got {value!r}")
        return False
    if limit is not None:
        try:
            limit.check(amount(int(value)), f"options.{key}", what)
        except LimitError as exc:
            problems.append(str(exc))
            return False
    return True


def _parse_tracks(data: dict[str, Any], metrics: list, problems: list[str]
                  ) -> tuple[tuple[str, ...], dict[str, str] | None, dict[str, Any]]:
    """Validate the optional ``tracks``, ``primary`` and ``pairs`` fields (appends problems)."""
    tracks = data.get("tracks", [])
    if not isinstance(tracks, list) or not all(isinstance(t, str) and t for t in tracks) \
            or len(set(tracks)) != len(tracks):
        problems.append(f"tracks must be a list of distinct names, got {tracks!r}")
        tracks = []
    primary = data.get("primary")
    if primary is not None:
        if not isinstance(primary, dict) or set(primary) != {"metric", "track"}:
            problems.append(f"primary must be {{'metric': m, 'track': t}}, got {primary!r}")
            primary = None
        else:
            if primary["metric"] not in metrics:
                problems.append(f"primary.metric {primary['metric']!r} is not in metrics")
            if primary["track"] not in tracks:
                problems.append(f"primary.track {primary['track']!r} is not in tracks {tracks}")
            primary = {"metric": str(primary["metric"]), "track": str(primary["track"])}
    pairs = data.get("pairs", {})
    if not isinstance(pairs, dict):
        problems.append(f"pairs must be an object, got {type(pairs).__name__}")
        return tuple(tracks), primary, {}
    for key in sorted(set(pairs) - {"seed", "per_track", "categories", "source_poses",
                                    "sources"}):
        problems.append(f"unknown field pairs.{key} (known: seed, per_track, categories, "
                        "source_poses, sources)")
    for key in ("categories", "source_poses"):
        vals = pairs.get(key)
        if vals is not None and (not isinstance(vals, list) or not vals
                                 or not all(isinstance(c, str) and c for c in vals)):
            problems.append(f"pairs.{key} must be a non-empty list of names, got {vals!r}")
    src = pairs.get("sources")
    if src is not None and src != "dataset" and not (
            isinstance(src, dict) and set(src) == {"pose", "subjects"}
            and isinstance(src["pose"], str) and isinstance(src["subjects"], int)
            and not isinstance(src["subjects"], bool) and src["subjects"] >= 1):
        problems.append(f"pairs.sources must be {{\"pose\": POSE_ID, \"subjects\": N >= 1}} "
                        f"or \"dataset\", got {src!r}")
    if pairs:
        seed = pairs.get("seed")
        if not isinstance(seed, int) or isinstance(seed, bool):
            problems.append(f"pairs.seed must be an integer, got {seed!r}")
        per = pairs.get("per_track")
        if not isinstance(per, dict) or not per:
            problems.append(f"pairs.per_track must map tracks to counts, got {per!r}")
        else:
            for t, n in per.items():
                if t not in tracks:
                    problems.append(f"pairs.per_track names track {t!r}, not in tracks {tracks}")
                if not isinstance(n, int) or isinstance(n, bool) or n < 1:
                    problems.append(f"pairs.per_track[{t!r}] must be an integer >= 1, got {n!r}")
                    continue
                try:  # a result table row per pair: per garment, at least this many rows
                    TABLE_ROWS.check(n, f"pairs.per_track[{t!r}]", "pairs per source garment")
                except LimitError as exc:
                    problems.append(str(exc))
    return tuple(tracks), primary, copy.deepcopy(pairs)
